#pragma once
/// @file dispatch.h
/// A run-time integer as a compile-time constant, so that a kernel is instantiated
/// for the values that matter (a B-spline order, a fan row's width) and its loops
/// over them are unrolled.

#include <type_traits>
#include <utility>

namespace vpffd {

/// Calls f(std::integral_constant<int, v>{}) when Lo <= v <= Hi, else
/// f(std::integral_constant<int, 0>{}) (the kernel's run-time form). Every call of f
/// must return the same type.
template <int Lo, int Hi, class F>
decltype(auto) with_constant(int v, F&& f) {
  static_assert(Lo > 0, "with_constant: 0 stands for values out of range");
  if constexpr (Lo > Hi) {
    (void)v;
    return f(std::integral_constant<int, 0>{});
  } else {
    if (v == Lo) return f(std::integral_constant<int, Lo>{});
    return with_constant<Lo + 1, Hi>(v, std::forward<F>(f));
  }
}

}  // namespace vpffd
