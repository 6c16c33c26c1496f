#pragma once
/// @file rounding.h
/// Rounding bounds for the Bernstein coefficients of det J computed in double.
///
/// The model (Higham, Accuracy and Stability of Numerical Algorithms, ch. 3): an
/// operation fl(a op b) = (a op b)(1 + delta), |delta| <= u = 2^-53, for + - * /
/// on normal numbers (an FMA rounds once, which only lowers the counts below).
/// Every Bernstein coefficient c of det J computed by the fold check is a sum of
/// elementary terms (signed products of input coordinates and of the positive
/// weights of Bezier extraction, subdivision and the binomial scaling). In the
/// computed value each term carries at most K factors (1 + delta), so
///     |fl(c) - c| <= gamma_K * sum |terms|,   gamma_K = K u / (1 - K u).
/// The sum of the absolute terms is bounded from the absolute nets that the
/// check carries alongside the control net (see certify.h), which are computed
/// by the same operations on |inputs| and so are low by at most a factor
/// (1 - gamma_K). The check then requires c > 2 gamma_K * bound: the factor 2
/// covers 1 / (1 - gamma_K)^3 and the few roundings of the bound itself while
/// gamma_K < 0.01 (K < 10^13).
///
/// Underflow breaks the relative model; the nets are scaled to magnitude <= 1
/// first, so every lost subnormal digit is below 2^-1074 times a factor <= 2^12,
/// and the check adds an absolute term K * 1e-300 that covers those.

#include <array>

namespace vpffd {

inline constexpr double kUnitRoundoff = 0x1p-53;
inline constexpr double kUnderflowSlack = 1e-300;

/// gamma_k = k u / (1 - k u).
inline double rounding_gamma(long k) {
  const double ku = static_cast<double>(k) * kUnitRoundoff;
  return ku / (1.0 - ku);
}

/// Largest number K of rounding factors on any elementary term of a Bernstein
/// coefficient of det J for a cell of the given degrees, subdivided `level` times.
///
/// Counting along the pipeline of certify.h, with S = sum d_a and T = prod (d_a + 1):
///  - translation of the control points to the cell's centre: 1;
///  - Bezier extraction (blossoms, certify.h / bezier_extraction.h): per axis
///    d stages, each a weight (two subtractions, one division: 3) times a value
///    (1) added to another (1): 5 d_a, so 5 S in all;
///  - the contraction of the extraction matrices with the control points: per
///    axis one product and at most d_a additions: 3 + S;
///  - de Casteljau at 1/2 (halving is exact): d_a additions per axis and level: level * S;
///  - the hodograph difference: 1; the binomial scaling: 1;
///    so a factor net carries at most F = 6 S + 6 + level * S;
///  - a cross component: two factors (2F), one product (1), a running sum of
///    at most 2T terms (2T): 2F + 1 + 2T;
///  - the dot product with the third factor: F more, one product, a running sum
///    of at most 3T terms: 3F + 2 + 5T in all.
/// A margin of 8 is added.
inline long det_rounding_steps(const std::array<int, 3>& degree, int level) {
  const long S = degree[0] + degree[1] + degree[2];
  const long T = long(degree[0] + 1) * (degree[1] + 1) * (degree[2] + 1);
  const long F = 6 * S + 6 + long(level) * S;
  return 3 * F + 2 + 5 * T + 8;
}

}  // namespace vpffd
