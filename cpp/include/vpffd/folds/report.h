#pragma once
/// @file report.h
/// What a fold check found: a verdict for the whole lattice, one status per
/// lattice cell, a witness point where det J < 0, and the bounds met on the way.

#include <array>
#include <cstdint>
#include <vector>

#include "vpffd/core/types.h"

namespace vpffd {

/// Status of one lattice cell (a box of non-empty knot spans).
enum class CellStatus : std::int8_t {
  Folded = -1,    ///< det J < 0 was proven at a point of the cell
  Unknown = 0,    ///< neither proven positive nor a negative point found within the depth
  Certified = 1,  ///< det J > 0 is proven on the whole closed cell
};

struct FoldReport {
  /// Cells per axis: the non-empty knot spans. Cell (i, j, k) is entry
  /// (i * cells[1] + j) * cells[2] + k of the per-cell arrays.
  std::array<int, 3> cells{0, 0, 0};
  /// Per axis, the knot span index s (t_s < t_{s+1}) of each cell.
  std::array<std::vector<int>, 3> spans;
  std::vector<CellStatus> status;
  /// Smallest det J (world units: volume ratio) at a point examined in the cell:
  /// the corners of every (sub)cell visited. An upper bound of the true minimum.
  std::vector<double> cell_min_det;
  /// A lower bound of det J over the cell: the smallest Bernstein coefficient of
  /// the cell's own net minus its rounding bound (convex hull property); at least 0
  /// for a certified cell, whose subdivision proved det J > 0.
  std::vector<double> cell_lower_bound;
  /// Subcells examined per cell (1: the cell itself decided the question).
  std::vector<std::int32_t> cell_subcells;

  bool certified = false;  ///< det J > 0 proven over the whole lattice domain
  bool folded = false;     ///< a point with det J < 0 was proven (never with certified)
  bool has_witness = false;
  Vector3d witness = Vector3d::Zero();      ///< rest-space point where det J < 0 (when folded)
  Vector3d witness_param = Vector3d::Zero();  ///< its parameters (u, v, w)
  double witness_det = 0;                   ///< det J there (as computed; its sign is proven)
  std::array<int, 3> witness_cell{-1, -1, -1};
  double min_det = 0;      ///< min of cell_min_det: the smallest det J found
  double lower_bound = 0;  ///< min of cell_lower_bound: det J >= this on the whole domain
  Index n_certified = 0, n_folded = 0, n_unknown = 0;
  Index n_refined = 0;   ///< cells that needed subdivision
  Index n_subcells = 0;  ///< (sub)cells examined in all
  int depth = 0;         ///< subdivision depth allowed
  double seconds = 0;    ///< wall time of the check
};

}  // namespace vpffd
