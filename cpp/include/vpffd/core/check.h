#pragma once
/// @file check.h
/// Always-on argument checks at the API boundary.

#include <sstream>
#include <string>

#include "vpffd/core/exceptions.h"

namespace vpffd::detail {

template <class... Args>
std::string concat(const Args&... args) {
  std::ostringstream os;
  (os << ... << args);
  return os.str();
}

}  // namespace vpffd::detail

/// Throws vpffd::InvalidInputError with the streamed message when `cond` is false.
/// Messages name the function and say what was expected and what was found.
#define VPFFD_CHECK(cond, ...)                                               \
  do {                                                                       \
    if (!(cond)) throw ::vpffd::InvalidInputError(::vpffd::detail::concat(__VA_ARGS__)); \
  } while (0)
