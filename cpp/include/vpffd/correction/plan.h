#pragma once
/// @file plan.h
/// FramePlan: what a frame's options amount to once checked against a Deformer
/// (Deformer::plan makes it). Every backend runs a frame from the same plan.

#include <vector>

#include "vpffd/core/types.h"
#include "vpffd/correction/solve.h"
#include "vpffd/lattice/embed.h"
#include "vpffd/lattice/periodic.h"

namespace vpffd {

/// What a frame's options amount to, checked: shared by the CPU and GPU paths so
/// both accept and refuse exactly the same input.
struct FramePlan {
  bool correcting = false;    ///< volume or constraints to correct
  bool measure = false;       ///< the volume is defined (closed mesh, or allow_open)
  double target = 0;          ///< target volume (with parts: the sum of part_targets)
  VectorXd part_targets;      ///< with parts: one target volume per part
  VectorXd inv_weight;        ///< N: 1 / weight, 0 for fixed control points
  Index free_points = 0;      ///< control points with inv_weight > 0 (checked against the conditions)
  Embedding sources;          ///< the constraint points embedded in the lattice
  std::vector<SparseVec> rows;  ///< per constraint: its basis row (control index, value)
  const Ties* ties = nullptr;   ///< periodic lattice: rows index the extended points (periodic.h)
};

}  // namespace vpffd
