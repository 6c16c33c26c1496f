#pragma once
/// @file frame_loop.h
/// One CPU frame as a function of (topology, rest state, control points, options):
/// the plan, the plain FFD, the axis steps (coefficients, closed-form solve, gather)
/// and the reorder into the caller's vertex order. It reads nothing else, so frames on
/// any number of threads run side by side, each on the rest state it was given.

#include <chrono>
#include <limits>
#include <memory>
#include <vector>

#include "vpffd/correction/constraints.h"
#include "vpffd/correction/tied_solve.h"
#include "vpffd/frame/frame_passes.h"
#include "vpffd/frame/frame_plan.h"
#include "vpffd/mesh/volume.h"

namespace vpffd::frame {

/// One frame: plain FFD with control points P (N x 3), then the volume correction and
/// point constraints of `opt`. The vertices go into `out` (#V x 3, row-major, caller
/// order) when it is not null, else into the result.
/// @throws InvalidInputError for bad options, SolverError when no correction exists
inline DeformResult run_frame(const FrameTopology& t, const RestState& s, const Eigen::Ref<const RowMatrixX3d>& P,
                              const CorrectionOptions& opt, double* out) {
  static const char axis_name[3] = {'x', 'y', 'z'};
  using Clock = std::chrono::steady_clock;
  const Index N = t.ties.n_distinct;
  const int threads = opt.threads;
  DeformResult res;
  FrameTimings& tm = res.timings;
  // A clock read per pass when timings are asked for, a branch otherwise.
  const bool timed = opt.record_timings;
  Clock::time_point t0{}, tick = timed ? Clock::now() : Clock::time_point{};
  if (timed) t0 = tick;
  auto lap = [&](double& slot) {
    if (!timed) return;
    const Clock::time_point now = Clock::now();
    slot += std::chrono::duration<double, std::milli>(now - tick).count();
    tick = now;
  };

  const FramePlan pl = make_plan(t, s, P, opt);
  const std::vector<SparseVec>& rows = pl.rows;
  lap(tm.plan);

  // --- plain FFD -------------------------------------------------------------
  res.target_volume = opt.preserve_volume ? pl.target : std::numeric_limits<double>::quiet_NaN();
  const int K = t.parts.count;
  // Nothing moves after the FFD of an uncorrected frame: it is written straight into
  // the caller's order, and its volume summed over the caller's faces, which (one part:
  // face_order is the identity) are processing_faces(t, s) face for face, the same terms
  // in the same order.
  const bool direct = !pl.correcting && K == 1;
  const int skip = first_step_sets(t, s, pl, opt);
  RowMatrixX3d Xs(direct ? 0 : t.n_vertices, 3);  // processing order
  if (!out) {
    res.vertices.resize(t.n_vertices, 3);
    out = res.vertices.data();
  }
  if (direct) {
    eval_ffd(t, s, P, out, threads, s.order->data());
  } else {
    eval_ffd(t, s, P, Xs.data(), threads, nullptr, skip);
  }
  double* X = Xs.data();
  res.offsets = RowMatrixX3d::Zero(N, 3);
  lap(tm.ffd);

  // --- axis steps -------------------------------------------------------------
  if (K > 1 && !opt.preserve_volume)
    res.part_volumes_before = part_volumes(X, processing_faces(t, s), t.face_start, t.origin, threads);
  if (K > 1 && opt.preserve_volume) {
    // One volume row per part in each step; the step's volume record is the whole mesh's.
    // The first step's coefficient pass measures the parts' volumes before any
    // correction (sum_v (x_v - o) w_v over each part's vertices): no face pass for them.
    const int naxes = static_cast<int>(opt.axes.size());
    const int k = naxes * opt.rounds;
    // Each step's weights; the last step's measure the volumes. Every entry is written
    // by a step's pass before it is read: not zeroed (3.5 MB a frame on the dragon).
    std::unique_ptr<double[]> w(new double[t.n_vertices]);
    const WeightAdjacency& adj = weight_adjacency(t, s, threads);
    for (int step = 0; step < k; ++step) {
      const int a = opt.axes[step % naxes];
      AxisStep info;
      info.axis = a;
      const bool last = step == k - 1;
      const bool sets = step == 0 && skip >= 0;  // X's column a is 0 (first_step_sets)
      const bool by_coefficients = sets || (!last && volume_by_coefficients(t, s, opt));
      PartCoefficients co = part_coefficients_rings(t.tables, s.embedding, adj.fans, X, a, t.origin, t.part_start,
                                                    threads, &s.runs, adj.weight_order.data(), w.get(),
                                                    !by_coefficients);
      const VectorXd Pa = expand_column(t.ties, P.col(a) + res.offsets.col(a), a);
      if (by_coefficients) co.volume = co.alpha * (Pa.array() - t.origin[a]).matrix();
      lap(tm.coefficients);
      info.volume_before = co.volume.sum();
      if (step == 0) {
        res.part_volumes_before = co.volume;
        res.volume_before = info.volume_before;
      }
      // Equal shares of what each part still misses: after the last axis every part is at its target.
      const VectorXd shares = (pl.part_targets - co.volume) / double(k - step);
      info.share = shares.sum();
      const std::vector<double> rhs = constraint_rhs(rows, opt.constraints, a, Pa);
      const VectorXd delta = solve_tied_parts(pl.ties, co.alpha.data(), co.alpha.cols(), K, shares.data(), rows, rhs,
                                              pl.inv_weight, axis_name[a], &info.sum_squares);
      info.max_offset = delta.cwiseAbs().maxCoeff();
      res.offsets.col(a) += delta;
      res.steps.push_back(info);
      lap(tm.solves);
      const VectorXd field = gather_field(t, delta, Pa, sets);
      // The last gather measures each part's volume with that step's weights (as the
      // one-part frame below): no face pass after the correction either.
      if (last)
        res.part_volumes = gather_final(t, s, field, X, a, w.get(), threads);
      else
        gather(t, s, field, X, a, threads);
      lap(tm.gathers);
    }
    res.volume = res.part_volumes.sum();
  } else if (!pl.correcting) {
    // Nothing moves: one volume is both the before and the after.
    if (pl.measure)
      res.volume_before = res.volume =
          direct ? signed_volume(out, t.faces, t.origin, threads)
                 : signed_volume(X, processing_faces(t, s), t.origin, threads);
    lap(tm.volume);
  } else if (!opt.preserve_volume) {
    // Constraints alone: the host steps, then each axis's total offsets at once.
    if (pl.measure) res.volume_before = signed_volume(X, processing_faces(t, s), t.origin, threads);
    lap(tm.volume);
    constraint_steps(pl, P, opt, res);
    lap(tm.solves);
    for (int a : opt.axes) gather(t, s, expand_offsets(t.ties, res.offsets.col(a)), X, a, threads);
    lap(tm.gathers);
    if (pl.measure) res.volume = signed_volume(X, processing_faces(t, s), t.origin, threads);
    lap(tm.volume);
  } else {
    const int naxes = static_cast<int>(opt.axes.size());
    const int k = naxes * opt.rounds;
    // The last step's weights: with them the last gather measures the volume
    // (the volume is linear in that axis's coordinates, V = sum_v (x_v - o) w_v).
    const bool fused = opt.method == CoefficientMethod::Traversal;
    std::unique_ptr<double[]> w(fused ? new double[t.n_vertices] : nullptr);  // written before read: not zeroed
    for (int step = 0; step < k; ++step) {
      const int a = opt.axes[step % naxes];
      const bool last = step == k - 1;
      AxisStep info;
      info.axis = a;
      // A closed mesh's passes write their weights somewhere in any case
      // (coefficients_fans): into w, one buffer for all steps.
      const bool sets = step == 0 && skip >= 0;  // X's column a is 0 (first_step_sets)
      const bool by_coefficients = sets || (!last && volume_by_coefficients(t, s, opt));
      AxisCoefficients co = coefficients(t, s, X, a, opt.method, threads,
                                         fused && (last || t.closed()) ? w.get() : nullptr, !by_coefficients);
      const VectorXd Pa = expand_column(t.ties, P.col(a) + res.offsets.col(a), a);
      if (by_coefficients) co.volume = co.alpha.dot((Pa.array() - t.origin[a]).matrix());
      lap(tm.coefficients);
      info.volume_before = co.volume;
      if (step == 0) res.volume_before = co.volume;
      // Equal shares of what is still missing: after the last axis the volume is the target.
      info.share = (pl.target - co.volume) / (k - step);
      const std::vector<double> rhs = constraint_rhs(rows, opt.constraints, a, Pa);
      const VectorXd delta =
          solve_tied(pl.ties, &co.alpha, info.share, rows, rhs, pl.inv_weight, axis_name[a], &info.sum_squares);
      const VectorXd field = gather_field(t, delta, Pa, sets);
      info.max_offset = delta.cwiseAbs().maxCoeff();
      res.offsets.col(a) += delta;
      res.steps.push_back(info);
      lap(tm.solves);
      if (last && fused) {
        res.volume = gather_final(t, s, field, X, a, w.get(), threads)[0];
      } else {
        gather(t, s, field, X, a, threads);
      }
      lap(tm.gathers);
    }
    if (!fused) res.volume = signed_volume(X, processing_faces(t, s), t.origin, threads);
    lap(tm.volume);
  }
  if (t.has_parts) {
    if (K > 1) {
      if (res.part_volumes.size() == 0)
        res.part_volumes = part_volumes(X, processing_faces(t, s), t.face_start, t.origin, threads);
    } else {
      res.part_volumes_before = VectorXd::Constant(1, res.volume_before);
      res.part_volumes = VectorXd::Constant(1, res.volume);
    }
    if (opt.preserve_volume) res.part_targets = pl.part_targets;
  }
  res.control_points = P + res.offsets;
  if (!direct) to_caller_order(s, Xs, out, threads);
  lap(tm.reorder);
  res.constraint_error = constraint_error(rows, expand_points(t.ties, res.control_points), opt.constraints);
  if (timed) {
    tm.recorded = true;
    tm.total = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  }
  return res;
}

}  // namespace vpffd::frame
