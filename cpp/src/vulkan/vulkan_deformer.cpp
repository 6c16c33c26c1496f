// VulkanDeformer: one frame of volume-preserving FFD as one queue submission.
//
// Device data (all in the device's vertex slot order, the construction's cell order):
//   X (3V float, (positions - origin) / scale), F (3F int), vertex-face adjacency,
//   per vertex the first control point index and the local parameter per axis,
//   the per-span power-form basis table, the slots sorted by cell and the tiles (runs
//   of <= 64 sorted slots of one cell), computed on the device from the rest positions
//   at construction and after every set_rest_vertices (rest_embedding.cpp).
// A frame runs: upload copies -> FFD -> [volume] -> per axis step [coefficients ->
// combine -> solve (offsets included) -> vertex update] -> volume -> [normals of the
// corrected control points, when asked] -> copies of the offsets, the step results,
// the volume partials [and the normals] to the host. Lengths on the
// device are in units of `scale`, the power of two nearest to the lattice's half
// diagonal: float-float has float32's exponent range (volume coefficients squared
// of a 1e-9 m mesh would underflow it, those of a 1e10 mm one overflow it), and a
// power of two scales every float exactly, so float64 results do not change. See
// shaders/common.glsl for the precision and determinism rules, shaders/real.glsl for
// the two kinds of sums (float64, float-float) and their common buffer layout.
//
// The frame's command buffer depends only on the options' shape (which steps along
// which axes, whether volumes are measured): it is recorded once per shape and
// submitted again while only the control points, targets and weights change, which
// live in buffers. Point constraints without a volume row do not depend on the mesh
// at all, so the host solves them (exactly as the CPU backend, errors included) and
// the device only applies the offsets.
//
// Parts (several closed objects, each keeping its own volume): the frame is the same
// with K coefficient rows and K volumes per step (solve.comp's solve_parts), per-part
// volume passes (volume.comp) before and after the steps, and each part's target in
// the frame parameters; the device's failure statuses are answered by the CPU backend's
// message (it names the parts), which runs the frame again on the host (errors only).
//
// Periodic lattices (setup.cpp): P is expanded to the extended lattice on the host, the
// device solves for the distinct control points; offsets, steps and results are the
// distinct points', as on the CPU.

#include "deformer_impl.h"
#include "vpffd/correction/errors.h"

namespace vpffd::vulkan {

using detail::get_real;
using detail::groups_for;
using detail::ms_since;
using detail::put_reals;

// ---- public API ----------------------------------------------------------------

VulkanDeformer::VulkanDeformer(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                               Lattice L, OutsidePolicy policy, const std::string& device,
                               Precision precision, const MeshParts* parts)
    : impl_(std::make_unique<Impl>()) {
  // The CPU frame layer's topology and first rest state: the input validated exactly as
  // the CPU backend does (the parts' checks included), the edge report, the embedding
  // and the exact (float64) rest volume, shared with the host Deformer of cpu().
  impl_->topo = make_topology(V, F, std::move(L), policy, parts);
  MoveScratch scratch;
  impl_->plan_state = vpffd::embed_rest(*impl_->topo, nullptr, V, 0, "Deformer", scratch);
  impl_->build(device, precision);
}

VulkanDeformer::~VulkanDeformer() = default;

const Deformer& VulkanDeformer::cpu() const { return impl_->synced_cpu(); }
const DeviceInfo& VulkanDeformer::device() const { return impl_->dev->info; }
Precision VulkanDeformer::precision() const { return impl_->precision; }
FrameTimings VulkanDeformer::last_timings() const {
  std::lock_guard<std::mutex> lock(impl_->frame_mutex);
  return impl_->timings;
}
const Vector3d& VulkanDeformer::origin() const { return impl_->origin; }
double VulkanDeformer::scale() const { return impl_->scale; }
std::uint64_t VulkanDeformer::vertex_buffer_handle() const {
  return reinterpret_cast<std::uint64_t>(impl_->buf[Impl::bX].handle());
}
std::uint64_t VulkanDeformer::index_buffer_handle() const {
  return reinterpret_cast<std::uint64_t>(impl_->buf[Impl::bF].handle());
}
const std::vector<std::int32_t>& VulkanDeformer::vertex_order() const { return impl_->slot; }
VectorXd VulkanDeformer::rest_part_volumes() const {
  std::lock_guard<std::mutex> lock(impl_->frame_mutex);
  const RestVolumes& v = impl_->rest_volumes();
  return impl_->K > 1 ? v.parts : VectorXd::Constant(1, v.total);
}

RowMatrixX3d VulkanDeformer::vertices() const {
  std::lock_guard<std::mutex> lock(impl_->frame_mutex);
  return impl_->read_vertices();
}

DeformResult VulkanDeformer::deform(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt,
                                    bool read_vertices, RowMatrixX3d* normals) {
  return impl_->run_frame(P, opt, read_vertices, normals, nullptr);
}

DeformResult VulkanDeformer::deform(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt,
                                    double* vertices, double* normals) {
  return impl_->run_frame(P, opt, /*read_vertices=*/vertices != nullptr, nullptr, nullptr, vertices, normals);
}

DeformResult VulkanDeformer::deform(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt,
                                    std::shared_ptr<const double>* vertices, double* normals) {
  VPFFD_CHECK(vertices != nullptr, "VulkanDeformer::deform: no place for the vertices' pointer");
  return impl_->run_frame(P, opt, /*read_vertices=*/true, nullptr, nullptr, nullptr, normals, vertices);
}

DeformResult VulkanDeformer::Impl::run_frame(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt,
                                             bool read_vertices, RowMatrixX3d* normals,
                                             const detail::FrameTail* tail, double* out_vertices,
                                             double* out_normals, std::shared_ptr<const double>* shared_vertices) {
  static const char axis_name[3] = {'x', 'y', 'z'};
  const auto t_start = std::chrono::steady_clock::now();
  Impl& m = *this;
  const FrameTopology& topo = *m.topo;
  const Index N = m.N;
  // One rest state from the options' checks to the read back: a move (which takes
  // this lock) waits for the frame, and the frame for it.
  std::unique_lock<std::mutex> lock(m.frame_mutex);
  CorrectionOptions moved_opt;
  const CorrectionOptions& po = m.plan_options(opt, moved_opt);

  // --- options: the CPU backend's own checks (the free control points and the
  // method included), so both refuse the same input ----------------------------------
  FramePlan pl = frame::make_plan(topo, *m.plan_state, P, po);  // the rest state: see plan_options
  // The default target is the rest volume this deformer computed (rest_embedding.cpp):
  // the same number at construction and after any move; with parts each part's.
  const bool has_parts = topo.has_parts;
  const int K = m.K;
  if (opt.preserve_volume && std::isnan(opt.target_volume) && opt.part_targets.empty()) {
    const RestVolumes& rest = m.rest_volumes();  // summed here on the first such frame after a move
    pl.target = rest.total;
    if (has_parts) pl.part_targets = K > 1 ? rest.parts : VectorXd::Constant(1, rest.total);
  }
  const bool correcting = pl.correcting;
  const bool measure = pl.measure;
  const double target = pl.target;
  // The device works with inverse weights scaled to a largest value of 1, as
  // solve_axis_offsets does on the CPU: the minimiser does not change, and the
  // sums stay in range whatever the units of the weights.
  const double wmax = pl.inv_weight.size() ? pl.inv_weight.maxCoeff() : 1.0;
  const VectorXd inv_weight = wmax > 0 ? VectorXd(pl.inv_weight / wmax) : pl.inv_weight;
  const size_t nc = opt.constraints.size();
  const std::vector<SparseVec>& rows = pl.rows;

  // --- what the device runs ---------------------------------------------------------
  const int naxes = static_cast<int>(opt.axes.size());
  const int k = correcting ? naxes * opt.rounds : 0;
  Shape shape;
  shape.measure = measure;
  shape.open = !topo.closed();
  shape.normals = normals != nullptr || out_normals != nullptr;
  DeformResult res;
  res.offsets = RowMatrixX3d::Zero(N, 3);
  if (opt.preserve_volume) {
    shape.mode = Shape::DeviceSteps;
    for (int step = 0; step < k; ++step) shape.axes.push_back(opt.axes[step % naxes]);
  } else if (correcting) {
    // Constraints alone do not depend on the mesh: the CPU backend's own steps, on the
    // host (same offsets, same errors); the device applies each axis's total once.
    shape.mode = Shape::HostOffsets;
    constraint_steps(pl, P, po, res);
    shape.axes = opt.axes;
  }

  // --- frame data ------------------------------------------------------------------------
  m.begin();  // one-time uploads, submitted just before the frame
  bool aux = false;
  if (shape.mode == Shape::DeviceSteps) {
    aux = m.update_constraints(rows, inv_weight);
    if (m.cons.bad) {
      // A constraint row that cannot move, or dependent rows: the CPU backend says which.
      detail::check(vkEndCommandBuffer(m.cmd), "vkEndCommandBuffer");
      m.submit_and_wait(&m.cmd, 1);  // the block is consistent with `cons` again
      lock.unlock();
      m.synced_cpu().deform(P, opt);
      throw dependent_rows_error(axis_name[opt.axes[0]], true, std::numeric_limits<double>::quiet_NaN());
    }
  }
  if (shape.normals && m.prepare_normals()) aux = true;  // before frame_commands: it may rebind
  const bool new_invw = m.invw_uploaded.size() != N || m.invw_uploaded != inv_weight;
  if (new_invw && shape.mode == Shape::DeviceSteps) {
    put_reals(m.up_invw.mapped(), inv_weight.data(), N, m.ff);
    m.copy(m.up_invw, m.buf[Impl::bInvW], 8 * N);
    aux = true;
  }
  {
    // The extended lattice's control points (periodic ties: copies, "shift" seams add
    // the extent in double, as the CPU's expand_points), each rounded once to float32.
    const RowMatrixX3d Q = expand_points(topo.ties, P);  // a copy of P without ties
    float* p = static_cast<float*>(m.up_P.mapped());
    for (Index c = 0; c < m.NE; ++c)
      for (int a = 0; a < 3; ++a) p[3 * c + a] = static_cast<float>((Q(c, a) - m.origin[a]) / m.scale);
  }
  const size_t n_fr = FR_RHS + 3 * nc + (K > 1 ? K : 0);
  m.reserve(Impl::bFrame, &m.up_frame, 8 * n_fr, "frame parameters");
  {
    std::vector<double> fr(n_fr, 0.0);
    // Volumes on the device are relative to the origin, like the CPU's; lengths in scale units.
    const double s = m.scale, s3 = s * s * s;
    fr[FR_TARGET] = target / s3;
    fr[FR_MAX_INVW] = inv_weight.maxCoeff();
    fr[FR_HI] = m.cons.hi;
    m.put_units(fr.data());
    for (int a = 0; a < 3; ++a) {
      const std::vector<double> rhs = constraint_rhs(rows, opt.constraints, a, expand_column(topo.ties, P.col(a), a));
      for (size_t i = 0; i < nc; ++i) fr[FR_RHS + a * nc + i] = rhs[i] / s;
    }
    // Parts: each one's target volume (solve.comp takes its share of what it misses).
    if (K > 1)
      for (int p = 0; p < K; ++p) fr[FR_RHS + 3 * nc + p] = pl.part_targets[p] / s3;
    put_reals(m.up_frame.mapped(), fr.data(), fr.size(), m.ff);
  }
  if (shape.mode == Shape::HostOffsets) {
    std::vector<double> dl(3 * N);
    for (int a = 0; a < 3; ++a)
      for (Index c = 0; c < N; ++c) dl[a * N + c] = res.offsets(c, a) / m.scale;
    put_reals(m.up_delta.mapped(), dl.data(), dl.size(), m.ff);
  }

  // --- submit: [a move's embedding,] [uploads,] the recorded frame -------------------------
  const Impl::Recorded& rec = m.frame_commands(shape);
  detail::check(vkEndCommandBuffer(m.cmd), "vkEndCommandBuffer");
  VkCommandBuffer cbs[5];
  std::uint32_t n_cbs = 0;
  // After every rebinding above (they drop recordings): the frame's first barrier
  // orders the embedding's writes before the FFD reads them.
  const VkCommandBuffer moved = m.pending_embedding();
  if (moved) cbs[n_cbs++] = moved;
  if (aux) cbs[n_cbs++] = m.cmd;
  cbs[n_cbs++] = rec.cb;
  // Shared vertices: straight into a buffer that becomes the result, when one is free.
  SharedReadback* const shared = shared_vertices ? m.free_shared_readback() : nullptr;
  if (read_vertices) cbs[n_cbs++] = m.readback_into(shared);
  if (tail) cbs[n_cbs++] = tail->record(shape.mode != Shape::Plain);
  const double prepared = ms_since(t_start);
  const auto t_submit = std::chrono::steady_clock::now();
  m.submit_and_wait(cbs, n_cbs);
  const double waited = ms_since(t_submit);
  m.embed_pending = false;
  if (new_invw && shape.mode == Shape::DeviceSteps) m.invw_uploaded = inv_weight;
  if (shape.normals) m.normals_ready = true;

  FrameTimings tm;
  tm.host_prepare = prepared;
  tm.host_submit_wait = waited;
  const std::uint32_t ns = rec.n_steps;
  if (m.dev->timestamps) {
    std::uint64_t ts[kQueries] = {};
    detail::check(vkGetQueryPoolResults(m.d, m.queries.get(), 0, 3 + ns, sizeof(std::uint64_t) * (3 + ns), ts,
                                        sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
                  "vkGetQueryPoolResults");
    const double p = m.dev->timestamp_period_ns * 1e-6;
    tm.has_timestamps = true;
    tm.gpu_total = double(ts[2 + ns] - ts[0]) * p;
    tm.gpu_ffd = double(ts[1] - ts[0]) * p;
    for (std::uint32_t s = 0; s < ns; ++s) tm.gpu_steps.push_back(double(ts[2 + s] - ts[1 + s]) * p);
    tm.gpu_final = double(ts[2 + ns] - ts[1 + ns]) * p;
    if (moved) {
      std::uint64_t tm_move[2] = {};
      detail::check(vkGetQueryPoolResults(m.d, m.queries.get(), kMoveQuery, 2, sizeof(tm_move), tm_move,
                                          sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
                    "vkGetQueryPoolResults");
      tm.gpu_move = double(tm_move[1] - tm_move[0]) * p;
    }
    if (read_vertices) {
      std::uint64_t tr[2] = {};
      detail::check(vkGetQueryPoolResults(m.d, m.queries.get(), kReadbackQuery, 2, sizeof(tr), tr,
                                          sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
                    "vkGetQueryPoolResults");
      tm.gpu_readback = double(tr[1] - tr[0]) * p;
    }
  }

  // --- results -------------------------------------------------------------------------
  // Step results: volume_before, share, sum_squares, max_offset, status, detail.
  // (in device units: lengths / scale, volumes / scale^3, sum_squares / scale^4)
  auto stat = [&](int step, int i) {
    return get_real(m.rb_stats.mapped(), ST_STEP + step * ST_STEP_STRIDE + i, m.ff);
  };
  const double s1 = m.scale, s3 = s1 * s1 * s1, s4 = s3 * s1;
  if (shape.mode == Shape::DeviceSteps) {
    for (int step = 0; step < k; ++step) {
      const char ax = axis_name[shape.axes[step]];
      const int status = static_cast<int>(stat(step, 4));
      if (status == 0) continue;
      // The frame ran but has no correction: its vertices must not outlive it.
      m.timings = tm;
      m.timings.host_total = ms_since(t_start);
      m.restore_vertices();
      if (K > 1) {
        // One row per part: the CPU backend names the parts and constraints at fault
        // (its solve meets the same rows); should its test pass, ours still stands.
        lock.unlock();
        m.synced_cpu().deform(P, opt);
        if (status == 1)
          throw SolverError(vpffd::detail::concat(
              "correction along ", ax, ": the volume coefficients of part ", static_cast<int>(stat(step, 5)),
              " are zero at every free control point (the part is flat along this axis, outside the lattice's "
              "reach, or every control point that influences it is fixed)"));
        throw dependent_rows_error(ax, true, std::numeric_limits<double>::quiet_NaN());
      }
      if (status == 1)
        throw zero_volume_row_error(ax);
      if (status == 3) {
        const double cond = stat(step, 5);  // < 0: infinite
        // The volume row depends on the constraints: the CPU backend gives its exact
        // message (its condition number); should its test pass, ours still stands.
        lock.unlock();
        m.synced_cpu().deform(P, opt);
        throw dependent_rows_error(ax, true, cond < 0 ? std::numeric_limits<double>::infinity() : cond);
      }
      throw DeviceError(vpffd::detail::concat("vulkan: the solve of step ", step, " reported status ", status));
    }
  }
  res.target_volume = opt.preserve_volume ? target : std::numeric_limits<double>::quiet_NaN();
  if (shape.mode == Shape::DeviceSteps) {
    for (int a = 0; a < 3; ++a)
      for (Index c = 0; c < N; ++c) res.offsets(c, a) = get_real(m.rb_delta.mapped(), a * N + c, m.ff) * s1;
    for (int step = 0; step < k; ++step) {
      AxisStep info;
      info.axis = shape.axes[step];
      info.volume_before = stat(step, 0) * s3;
      info.share = stat(step, 1) * s3;
      info.sum_squares = stat(step, 2) * wmax * s4;  // in the caller's weights
      info.max_offset = stat(step, 3) * s1;
      res.steps.push_back(info);
    }
  }
  res.control_points = P + res.offsets;
  if (measure) {
    // The volume passes' per-workgroup partials, added in a fixed order; with parts
    // each part's g_part partials, then the parts in order (the CPU's sums of them).
    const std::uint32_t per = K > 1 ? m.g_part : m.g_face;
    VectorXd before = VectorXd::Zero(K), after = VectorXd::Zero(K);
    for (int p = 0; p < K; ++p)
      for (std::uint32_t g = 0; g < per; ++g) {
        before[p] += get_real(m.rb_red.mapped(), p * per + g, m.ff);
        after[p] += get_real(m.rb_red.mapped(), kMaxGroups + p * per + g, m.ff);
      }
    before *= s3;
    after *= s3;
    // Device steps have no volume pass before them: the first step's solve leaves each
    // part's volume from its coefficient pass.
    if (shape.mode == Shape::DeviceSteps && k > 0)
      for (int p = 0; p < K; ++p) before[p] = get_real(m.rb_stats.mapped(), ST_PART_BEFORE + p, m.ff) * s3;
    if (shape.mode == Shape::Plain) after = before;
    res.volume_before = before.sum();
    res.volume = after.sum();
    if (has_parts) {
      res.part_volumes_before = before;
      res.part_volumes = after;
    }
  }
  if (has_parts && opt.preserve_volume) res.part_targets = pl.part_targets;
  res.constraint_error = constraint_error(rows, expand_points(topo.ties, res.control_points), opt.constraints);
  // Under the frame's lock: another thread's frame would overwrite rb_X.
  const auto t_unpack = std::chrono::steady_clock::now();
  if (shared) {
    if (!m.direct_readback()) m.unpack(m.rb_X, m.scale, m.origin, shared->frame->host.data());
    *shared_vertices = std::shared_ptr<const double>(shared->frame, shared->frame->data());
  } else if (shared_vertices) {
    // Every shared buffer is held (or float-float): new memory, copied into.
    auto x = std::make_shared<RowMatrixX3d>(m.nv, 3);
    m.unpack(m.rb_X, m.scale, m.origin, x->data());
    *shared_vertices = std::shared_ptr<const double>(x, x->data());
  } else if (read_vertices && out_vertices)
    m.unpack(m.rb_X, m.scale, m.origin, out_vertices);
  else if (read_vertices)
    res.vertices = m.unpack_vertices();
  if (normals) *normals = m.unpack_normals();
  if (out_normals) m.unpack(m.rb_N, 1.0, Vector3d::Zero(), out_normals);
  tm.host_unpack = ms_since(t_unpack);
  if (tail) tail->finish();
  tm.host_total = ms_since(t_start);
  m.timings = std::move(tm);
  return res;
}

}  // namespace vpffd::vulkan
