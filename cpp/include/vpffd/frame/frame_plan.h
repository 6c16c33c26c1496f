#pragma once
/// @file frame_plan.h
/// A frame's plan: its inputs checked and what every backend needs prepared (the
/// targets, the constraints' basis rows, the weights), as a function of (topology,
/// rest state, control points, options). The same checks and words on every backend:
/// the Vulkan backend plans through this too.

#include <cmath>
#include <limits>
#include <string>

#include "vpffd/correction/constraints.h"
#include "vpffd/correction/options.h"
#include "vpffd/correction/plan.h"
#include "vpffd/correction/solve.h"
#include "vpffd/frame/frame_passes.h"
#include "vpffd/frame/rest_state.h"
#include "vpffd/lattice/embed.h"
#include "vpffd/lattice/periodic.h"

namespace vpffd::frame {

/// A volume-preserving frame of a closed mesh: refuses a rest volume below the
/// normal doubles (a mesh of extent ~1e-150: its volume underflows, and "keeping"
/// 0 would keep nothing), and targets that are zero or of the other sign than the
/// rest volume (each part's with parts) unless `allow_inversion`, and targets more
/// than 1e30 times larger or smaller than the rest volume.
constexpr double kMaxVolumeRatio = 1e30;
inline void check_targets(const FrameTopology& t, const RestState& s, const FramePlan& pl, bool allow_inversion) {
  const RestVolumes& rest = rest_volumes(t, s);
  const int K = t.has_parts ? t.parts.count : 1;
  const Vector3d ext = t.lattice.box_max - t.lattice.box_min;
  for (int k = 0; k < K; ++k) {
    const double r = t.has_parts && K > 1 ? rest.parts[k] : rest.total;
    const double target = t.has_parts ? pl.part_targets[k] : pl.target;
    const std::string which = K > 1 ? detail::concat(" of part ", k) : std::string();
    VPFFD_CHECK(std::abs(r) >= std::numeric_limits<double>::min(), "deform: the rest volume", which, " (", r,
                ") is below the smallest normal double (2.2e-308): it underflows at this scale (lattice box ",
                ext.maxCoeff(), " wide), so no correction can keep it; scale the mesh and lattice up (by a power "
                "of two) and the result back");
    if (!allow_inversion)
      VPFFD_CHECK(target != 0.0 && (target > 0) == (r > 0), "deform: the target volume", which, " (", target,
                  ") is zero or of the other sign than the rest volume (", r,
                  "): the surface would be flattened or turned inside out; pass allow_inversion=True if that "
                  "is meant");
    // A volume 1e30 times the rest volume moves vertices ~1e10 times the mesh's size:
    // past that the device's float32 positions (relative to the box, 3.4e38) run out
    // well before double's. Both backends refuse the same targets.
    // (A zero target, allowed with allow_inversion above, flattens: no bound below.)
    VPFFD_CHECK(std::abs(target) <= kMaxVolumeRatio * std::abs(r) &&
                    (target == 0.0 || std::abs(target) * kMaxVolumeRatio >= std::abs(r)),
                "deform: the target volume", which, " (", target, ") is ", std::abs(target / r),
                " times the rest volume (", r, "): more than 1e30 times larger or smaller, which would move "
                "vertices far beyond the lattice (the Vulkan backend's float32 positions cannot hold them); give "
                "a target within a factor of 1e30 of the rest volume");
  }
}

/// Checks P and `opt` and prepares what any backend needs for the frame.
/// @throws InvalidInputError naming the problem
inline FramePlan make_plan(const FrameTopology& t, const RestState& rest, const Eigen::Ref<const RowMatrixX3d>& P,
                           const CorrectionOptions& opt) {
  static const char axis_name[3] = {'x', 'y', 'z'};
  const Index N = t.ties.n_distinct;
  check_control_points(t, P, "deform");
  FramePlan plan;
  if (!t.ties.identity) plan.ties = &t.ties;
  plan.correcting = opt.preserve_volume || !opt.constraints.empty();
  if (plan.correcting) VPFFD_CHECK(!opt.axes.empty(), "deform: axes is empty; name at least one of x, y, z");
  VPFFD_CHECK(opt.rounds >= 1 && opt.rounds <= kMaxRounds, "deform: rounds is ", opt.rounds, "; expected 1..",
              kMaxRounds);
  for (size_t i = 0; i < opt.axes.size(); ++i) {
    VPFFD_CHECK(opt.axes[i] >= 0 && opt.axes[i] < 3, "deform: axis ", opt.axes[i], " not in 0..2");
    for (size_t j = 0; j < i; ++j)
      VPFFD_CHECK(opt.axes[j] != opt.axes[i], "deform: axes repeats ", axis_name[opt.axes[i]],
                  "; name each axis once (rounds repeats them)");
  }
  plan.inv_weight = VectorXd::Ones(N);
  if (opt.weights.size() > 0) {
    VPFFD_CHECK(opt.weights.size() == N, "deform: ", opt.weights.size(), " weights, expected one per control point (",
                N, ")");
    for (Index c = 0; c < N; ++c)
      VPFFD_CHECK(std::isfinite(opt.weights[c]) && opt.weights[c] > 0 && std::isfinite(1.0 / opt.weights[c]),
                  "deform: weight ", c, " is ", opt.weights[c],
                  "; weights must be finite and positive, and not so small that 1/weight overflows "
                  "(use fixed= to pin control points)");
    plan.inv_weight = opt.weights.cwiseInverse();
  }
  if (!opt.fixed.empty()) {
    VPFFD_CHECK(Index(opt.fixed.size()) == N, "deform: fixed has ", opt.fixed.size(),
                " entries, expected one per control point (", N, ")");
    for (Index c = 0; c < N; ++c)
      if (opt.fixed[c]) plan.inv_weight[c] = 0.0;
  }
  if (opt.preserve_volume && !opt.allow_open) require_closed(t.edges, "deform(preserve_volume=True)");
  plan.measure = t.closed() || opt.allow_open;
  // The rest volume is the default target of a volume-preserving frame only: other
  // frames do not sum it (frame/rest_volume.h).
  plan.target = !std::isnan(opt.target_volume) ? opt.target_volume
                : opt.preserve_volume && !t.has_parts ? rest_volumes(t, rest).total
                                                     : 0.0;
  VPFFD_CHECK(std::isfinite(plan.target), "deform: target_volume is ", plan.target, "; expected a finite number");
  if (t.has_parts) {
    const int K = t.parts.count;
    if (!opt.part_targets.empty()) {
      VPFFD_CHECK(Index(opt.part_targets.size()) == K, "deform: ", opt.part_targets.size(),
                  " target volumes, expected one per part (", K, ")");
      VPFFD_CHECK(std::isnan(opt.target_volume), "deform: give either one target volume per part or target_volume");
      plan.part_targets = Eigen::Map<const VectorXd>(opt.part_targets.data(), K);
      for (int k = 0; k < K; ++k)
        VPFFD_CHECK(std::isfinite(plan.part_targets[k]), "deform: the target volume of part ", k, " is ",
                    plan.part_targets[k], "; expected a finite number");
    } else if (!std::isnan(opt.target_volume)) {
      VPFFD_CHECK(K == 1, "deform: one target_volume for ", K,
                  " parts; give one target volume per part (a sequence of ", K, " numbers)");
      plan.part_targets = VectorXd::Constant(1, opt.target_volume);
    } else if (opt.preserve_volume) {
      plan.part_targets = rest_volumes(t, rest).parts;
    } else {
      plan.part_targets = VectorXd::Zero(K);  // read by no frame that does not preserve volume
    }
    plan.target = plan.part_targets.sum();
    VPFFD_CHECK(std::isfinite(plan.target), "deform: the target volumes' sum is ", plan.target,
                "; expected a finite number");
    if (opt.preserve_volume && K > 1)
      VPFFD_CHECK(opt.method == CoefficientMethod::Traversal,
                  "deform: method='csr' keeps one volume; with several parts use method='traversal'");
  } else {
    VPFFD_CHECK(opt.part_targets.empty(), "deform: ", opt.part_targets.size(),
                " target volumes per part, but this Deformer was built without parts");
  }

  if (opt.preserve_volume && !opt.allow_open) check_targets(t, rest, plan, opt.allow_inversion);

  // Constraint sources: basis rows at their parameters.
  const size_t nc = opt.constraints.size();
  plan.rows.resize(nc);
  RowMatrixX3d pts(static_cast<Index>(nc), 3);
  for (size_t s = 0; s < nc; ++s) {
    const PointConstraint& pc = opt.constraints[s];
    VPFFD_CHECK(pc.target.allFinite(), "deform: constraint ", s, " has a non-finite target");
    if (pc.vertex >= 0) {
      VPFFD_CHECK(pc.vertex < t.n_vertices, "deform: constraint ", s, " names vertex ", pc.vertex, ", but there are ",
                  t.n_vertices, " vertices");
      pts.row(s) = rest.V->row(pc.vertex);
    } else {
      VPFFD_CHECK(pc.point.allFinite(), "deform: constraint ", s, " has a non-finite source point");
      pts.row(s) = pc.point.transpose();
    }
  }
  plan.sources = embed(t.lattice, pts, t.policy, 1, "constraint point");
  // The rows give the wrapped point's image; a "shift" seam would add a translation the
  // right-hand sides do not carry.
  if (seam_translations(t.lattice, pts).rows() > 0)
    for (size_t s = 0; s < nc; ++s)
      VPFFD_CHECK(seam_translations(t.lattice, pts.row(s)).rows() == 0, "deform: constraint ", s,
                  " has its source outside the box along a periodic axis with the 'shift' seam; give the source "
                  "inside the box (moved by whole extents) and its target moved by the same amount");
  const int per = t.tables.order[0] * t.tables.order[1] * t.tables.order[2];
  for (size_t s = 0; s < nc; ++s) {
    plan.rows[s].index.resize(per);
    plan.rows[s].value.resize(per);
    point_basis_entries(t.tables, plan.sources, static_cast<Index>(s), plan.rows[s].index.data(),
                        plan.rows[s].value.data());
  }

  // A constraint along an axis that is not corrected could only be met by luck.
  bool corrected[3] = {false, false, false};
  for (int a : opt.axes) corrected[a] = plan.correcting;
  const double diag = (t.lattice.box_max - t.lattice.box_min).norm();
  for (size_t s = 0; s < nc; ++s)
    for (int a = 0; a < 3; ++a)
      if (!corrected[a]) {
        const double S = row_dot(plan.rows[s], expand_column(t.ties, P.col(a), a));
        VPFFD_CHECK(std::abs(S - opt.constraints[s].target[a]) <= 1e-9 * diag, "deform: constraint ", s,
                    " moves its point along ", axis_name[a], " (from ", S, " to ", opt.constraints[s].target[a],
                    "), but ", axis_name[a], " is not among the corrected axes");
      }

  // Checks that the first axis step would make: made here so that a frame that
  // cannot be corrected fails before any work, with the same message on every backend.
  plan.free_points = count_free_points(plan.inv_weight);
  if (opt.preserve_volume) check_method(t, opt.method);
  if (plan.correcting)
    check_free_points(opt.preserve_volume ? t.parts.count : 0, nc, plan.free_points, axis_name[opt.axes[0]]);
  return plan;
}

}  // namespace vpffd::frame
