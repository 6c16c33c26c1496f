#pragma once
/// @file errors.h
/// The solver's refusals, worded once for every backend: the CPU solve (solve.h) and
/// the Vulkan backend, whose device solve reports a status, raise the same errors.

#include <cmath>
#include <limits>

#include "vpffd/core/check.h"
#include "vpffd/core/exceptions.h"

namespace vpffd {

/// The volume row of an axis step is zero at every free control point.
inline SolverError zero_volume_row_error(char axis) {
  return SolverError(detail::concat("correction along ", axis,
                                    ": the volume coefficients of the free control points are all zero "
                                    "(the mesh is flat along this axis, or every control point that "
                                    "influences it is fixed)"));
}

/// The rows of one step (the volume row, when `with_volume`, and the point
/// constraints) are linearly dependent; `condition` is the condition number of their
/// unit-diagonal Gram matrix (infinite when singular, NaN when not computed).
inline SolverError dependent_rows_error(char axis, bool with_volume, double condition) {
  const std::string what = with_volume ? "volume and point" : "point";
  if (std::isnan(condition))
    return SolverError(detail::concat("correction along ", axis, ": the ", what,
                                      " constraints are linearly dependent; two constraints on the same point, or "
                                      "a constraint the volume row already fixes?"));
  return SolverError(detail::concat("correction along ", axis, ": the ", what,
                                    " constraints are linearly dependent (condition number ", condition,
                                    "); two constraints on the same point, or a constraint the volume row "
                                    "already fixes?"));
}

}  // namespace vpffd
