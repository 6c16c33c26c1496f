#pragma once
/// @file exceptions.h
/// The exceptions the library throws. Python sees them as vpffd.InvalidInputError
/// (a ValueError), vpffd.SolverError, vpffd.MeshIOError, vpffd.BackendUnavailableError
/// and vpffd.DeviceError (RuntimeErrors).

#include <stdexcept>
#include <string>

namespace vpffd {

/// Bad argument: wrong shape, non-finite value, index out of range, open mesh...
struct InvalidInputError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

/// A correction that has no solution (zero coefficients, singular constraints).
struct SolverError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// A mesh file that cannot be read or written.
struct MeshIOError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// A backend asked for by name that is not compiled in or has no usable device.
struct BackendUnavailableError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// A failing call on a compute device (names the call and its result code).
struct DeviceError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace vpffd
