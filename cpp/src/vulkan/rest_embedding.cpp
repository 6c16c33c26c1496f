// Rest positions on the device: VulkanDeformer::set_rest_vertices, and the embedding
// that construction shares with it (the two-phase evaluation of paper 001, §3: the
// basis data of every vertex is computed on the device from its rest position, so an
// object can travel through the lattice frame by frame).
//
// Design:
// - Device vertex slots keep the construction's order (the CPU Deformer's cell order of
//   the first rest mesh): faces, adjacency and every per-slot buffer keep their layout,
//   and a move changes only the rest positions, span/tau per slot and the cell tables.
// - Per move the host uploads X only, in the caller's vertex order (slot v reads its
//   position at slot_vertex[v]: a gather on the device, where the host's read X at
//   random), converted to the device's reals ((x - origin) / scale, float64 or
//   float-float: the embedding then starts from the positions' own precision, not
//   float32's). That conversion reads every coordinate anyway, so the finiteness,
//   too-far and outside tests ride along, with the CPU's rule in double: exactly the
//   vertices Deformer::set_rest_vertices refuses are refused (no device counter, no
//   read-back), and in that error case the CPU's embed() runs to give its exact
//   message (how many, the first one). The rest volume is summed on the host in
//   float64 (signed_volume, O(F), no embedding) on its first use after the move
//   (frame/rest_volume.h: a plain frame does not read it): the very number a CPU
//   Deformer of the moved mesh keeps, so preserve_volume aims at the same target on
//   both backends; the device's volumes sum float32 positions, which would miss it by
//   ~1e-7.
// - A move's device work (embed_cb, recorded once) is not submitted by
//   set_rest_vertices: it goes first in the next frame's submission (one submission
//   and one wait per frame, as the paper's two-phase evaluation runs), or alone when
//   something reads the device before a frame (flush_embedding). Moves in a row
//   without a frame between them embed only the last one (up_rest holds its positions).
// - On the device (embed_cb): embed.comp (span, tau and
//   cell per slot; X = the rest positions), an LSD radix sort of the (cell, slot) pairs
//   (radix.comp with scan.comp: 8 bits per pass, integer work only and
//   stable, so the order never depends on scheduling: (cell, slot) ascending), then
//   tiles.comp: each cell's range, its tile count, their scan, the tiles. coef.comp
//   reads a tile's slots through the sorted array; combine.comp adds, per control
//   point, the partials of the tiles of its <= K^3 cells in tile order. The number of
//   tiles varies with the positions; NTILE is its upper bound ceil(V/64) + min(V, cells),
//   so the pipelines never change (the extra tiles are empty).
// - Periodic axes: the host tests the positions wrapped as the CPU's embed() does
//   (wrap_point, so the same vertices are refused) but uploads them as given; embed.comp
//   wraps them itself and keeps per slot the shift seam's translation and the twist
//   seam's mirror (bSeam), which ffd.comp and normals.comp apply. Positions over 2^24
//   extents away along a periodic axis are refused (the device's reals and float32
//   positions keep nothing of their place in the box; the CPU takes them).
// - Point constraints at vertices take their basis at the vertex's current rest
//   position: after a move frames pass them to the CPU's plan as point constraints at
//   that position (the plan embeds those few points on the host). The default volume
//   target is rest_volumes(), at construction too (the same code, so moving back to the
//   construction's positions gives its frames bit for bit).
// - Parts: embed.comp puts each slot's part above its cell in the sort key, so the sort
//   groups each part's slots (as the CPU's part_start) and tiles never straddle parts;
//   the rest part volumes are summed on the host (part_volumes over the faces grouped
//   by part, the CPU's own function and face order), their sum is the rest volume.
// - The host Deformer `host` (ffd, jacobians, matrices, error messages) follows a
//   move lazily: frames do not need it, and synced_cpu() re-embeds it on the host on
//   its first use after a move.

#include <atomic>
#include <limits>
#include <type_traits>

#include "deformer_impl.h"
#include "vpffd/core/parallel.h"
#include "vpffd/lattice/embed.h"
#include "vpffd/mesh/validate.h"
#include "vpffd/mesh/volume.h"
#include "vpffd/volume/part_coefficients.h"

namespace vpffd::vulkan {

void VulkanDeformer::Impl::record_embedding(bool offsets) {
  VkCommandBuffer& slot_cb = offsets ? offset_cb : embed_cb;
  slot_cb = detail::allocate_command_buffer(d, cmd_pool.get());
  const VkCommandBuffer cb = slot_cb;
  begin(cb, false);
  if (dev->timestamps) {
    vkCmdResetQueryPool(cb, queries.get(), kMoveQuery, 2);
    vkCmdWriteTimestamp(cb, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, queries.get(), kMoveQuery);
  }
  barrier(cb);
  if (offsets)
    copy(cb, up_offsets, buf[bRest], 24 * VkDeviceSize(K), 0, 8 * VkDeviceSize(offsets_at));
  else
    copy(cb, up_rest, buf[bRest], 24 * nv);
  vkCmdFillBuffer(cb, buf[bSort].handle(), 16 * nv, 8 * NE * K, 0);  // keys without vertices: empty ranges
  vkCmdFillBuffer(cb, buf[bTiles].handle(), 0, VK_WHOLE_SIZE, 0);  // tiles past the real ones: empty
  barrier(cb);
  vkCmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl.layout.get(), 0, 1, &pl.set, 0, nullptr);
  Push pc;
  pc.flags = (topo->policy == OutsidePolicy::Error ? EM_CLAMP : 0) | (offsets ? EM_OFFSET : 0);
  dispatch(cb, kEmbed, g_vert, pc);
  for (std::uint32_t pass = 0; pass < sort_passes; ++pass) {
    Push s;
    s.step = static_cast<std::int32_t>(pass);
    s.count = static_cast<std::int32_t>(sort_blocks);
    s.flags = 0;  // count
    dispatch(cb, kRadix, sort_blocks, s);
    Push sc;
    sc.count = static_cast<std::int32_t>(VPFFD_SORT_DIGITS * sort_blocks);
    dispatch(cb, kScan, 1, sc);
    s.flags = 1;  // scatter
    dispatch(cb, kRadix, sort_blocks, s);
  }
  Push t;
  t.flags = 0;
  dispatch(cb, kTiles, g_vert, t);
  t.flags = 1;
  dispatch(cb, kTiles, g_cp, t);
  Push sc;
  sc.count = static_cast<std::int32_t>(NE * K + 1);
  dispatch(cb, kScan, 1, sc);
  t.flags = 2;
  dispatch(cb, kTiles, g_cp, t);
  timestamp(cb, kMoveQuery + 1);
  detail::check(vkEndCommandBuffer(cb), "vkEndCommandBuffer");
}

void VulkanDeformer::Impl::stage_rest(const Eigen::Ref<const RowMatrixX3d>& X, const char* where) {
  VPFFD_CHECK(X.rows() == nv, where, ": ", X.rows(), " vertices, the mesh has ", nv,
              " (the faces stay; give every vertex a new position)");
  const Lattice& L = topo->lattice;
  const bool refuse_outside = topo->policy == OutsidePolicy::Error;
  // embed()'s tests, in the same double arithmetic (lattice/embed.h's rules).
  AxisInterval box[3], reach[3];
  for (int a = 0; a < 3; ++a) {
    box[a] = accepted_box(L, a);
    reach[a] = accepted_parameters(L, a);
  }
  const bool periodic = L.any_periodic();
  // On a periodic axis any distance is inside, but the device wraps in reals (float-float:
  // 48 bits) and keeps positions in float32: past 2^24 box extents nothing of the place
  // within the box would be left, so such a position is refused (the CPU takes it).
  const double far_extents = std::ldexp(1.0, 24);
  // In parallel: this is most of the host's share of a move (the device
  // embeds and sorts), and serial it cost several device frames (5.9 ms for the 112,848
  // whales on an H100 machine against a 1.1 ms frame). In the caller's vertex order: X is
  // read and the upload written as streams (embed.comp and rest_normals.comp find a slot's
  // position through slot_vertex). Each vertex's upload entries are its own.
  //
  // The tests as "inside" comparisons, which a NaN fails (an infinity fails the parameter
  // range): one form for every test and lane, so that without periodic axes the loop
  // takes four vertices (12 coordinates) a step with the axis constants repeated four
  // times, and vectorises (bench/results/vm/vulkan_move_host_vm.md). Constants in locals: read through `L` or this Impl, they were reloaded
  // after every store into the upload buffer (which might alias them). On a periodic
  // axis the test is of the wrapped position and the far limit is finite; elsewhere the
  // limit is infinite (a NaN fails it too, but is refused as bad first).
  struct Lanes {
    double lo[12], hi[12], u_lo[12], u_hi[12], p_lo[12], p_k[12], box_lo[12], centre[12], far[12], origin[12];
  } c;
  const ParameterMap to_parameter(L);  // parameter_of's map, made once
  const double inf = std::numeric_limits<double>::infinity();
  for (int j = 0; j < 12; ++j) {
    const int a = j % 3;
    c.lo[j] = refuse_outside ? box[a].lo : -inf;
    c.hi[j] = refuse_outside ? box[a].hi : inf;
    c.u_lo[j] = reach[a].lo;
    c.u_hi[j] = reach[a].hi;
    c.p_lo[j] = to_parameter.lo[a];
    c.p_k[j] = to_parameter.k[a];
    c.box_lo[j] = to_parameter.box_min[a];
    c.centre[j] = 0.5 * (L.box_min[a] + L.box_max[a]);
    c.far[j] = L.periodic(a) ? far_extents * (L.box_max[a] - L.box_min[a]) : inf;
    c.origin[j] = origin[a];
  }
  const double inv_scale = 1.0 / scale;  // a power of two: x * inv_scale == x / scale
  std::atomic<bool> bad{false}, far{false};
  // The host's copy of the positions is written in the same pass (X read once), into
  // spare_rest: embed_rest swaps it in once nothing can throw.
  spare_rest.resize(nv, 3);
  double* const keep = spare_rest.data();
  auto stage = [&](auto ff_c) {
    constexpr bool FF = decltype(ff_c)::value;
    double* const y64 = static_cast<double*>(up_rest.mapped());
    float* const yff = static_cast<float*>(up_rest.mapped());
    // Coordinate k of the upload from x (lane j's constants) and xw, the position tested
    // (x wrapped along periodic axes): its "inside" and "near" flags.
    auto put = [&](Index k, int j, double x, double xw, bool& in, bool& near) {
      const double u = c.p_lo[j] + (xw - c.box_lo[j]) * c.p_k[j];  // ParameterMap's arithmetic
      in &= (u >= c.u_lo[j]) & (u <= c.u_hi[j]) & (xw >= c.lo[j]) & (xw <= c.hi[j]);
      near &= std::abs(x - c.centre[j]) <= c.far[j];
      keep[k] = x;
      const double y = (x - c.origin[j]) * inv_scale;
      if constexpr (FF) {
        const float h = static_cast<float>(y);
        yff[2 * k] = h;
        yff[2 * k + 1] = static_cast<float>(y - double(h));
      } else {
        y64[k] = y;
      }
    };
    parallel_range(nv, 0, [&](Index b, Index e) {
      bool in = true, near = true;
      Index i = b;
      if (!periodic && X.outerStride() == 3)  // rows of three in a row (not a strided view)
        for (; i + 4 <= e; i += 4) {
          const double* x = X.data() + 3 * i;
          bool in4 = true, near4 = true;
          for (int j = 0; j < 12; ++j) put(3 * i + j, j, x[j], x[j], in4, near4);
          in &= in4;
          near &= near4;
        }
      for (; i < e; ++i) {
        double x[3] = {X(i, 0), X(i, 1), X(i, 2)}, xw[3] = {x[0], x[1], x[2]};
        if (periodic) {
          // embed() tests the point wrapped along periodic axes (the device wraps it
          // again, embed.comp: only the positions are uploaded).
          const Vector3d w = wrap_point(L, Vector3d(x[0], x[1], x[2]));
          for (int a = 0; a < 3; ++a) xw[a] = w[a];
          for (int a = 0; a < 3; ++a) in &= std::isfinite(x[a]) & std::isfinite(xw[a]);
        }
        for (int a = 0; a < 3; ++a) put(3 * i + a, a, x[a], xw[a], in, near);
      }
      if (!in) bad.store(true, std::memory_order_relaxed);
      if (!near) far.store(true, std::memory_order_relaxed);
    });
  };
  if (ff)
    stage(std::true_type{});
  else
    stage(std::false_type{});
  if (bad || far) refuse_rest(X, where);
}

void VulkanDeformer::Impl::refuse_rest(const Eigen::Ref<const RowMatrixX3d>& X, const char* where) const {
  const Lattice& L = topo->lattice;
  // The CPU's own checks give the message (first vertex in the caller's order).
  require_finite_rows(X, where);
  try {
    embed(L, X, topo->policy);
  } catch (const InvalidInputError& e) {
    throw InvalidInputError(std::string(where) + ": " + e.what() + vpffd::parts_outside(*topo, X));
  }
  for (Index v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a) {
      if (!L.periodic(a)) continue;
      const double centre = 0.5 * (L.box_min[a] + L.box_max[a]), extent = L.box_max[a] - L.box_min[a];
      VPFFD_CHECK(std::abs(X(v, a) - centre) <= std::ldexp(1.0, 24) * extent, where, ": vertex ", v, " lies ",
                  std::abs(X(v, a) - centre) / extent, " box extents away along periodic axis ", "xyz"[a],
                  "; the Vulkan backend wraps positions up to 2^24 extents away (its float32 positions keep "
                  "nothing of the place in the box beyond); move the mesh back by whole extents");
    }
}

void VulkanDeformer::Impl::embed_rest(const Eigen::Ref<const RowMatrixX3d>& X, const char* where, bool defer) {
  // stage_rest fills up_rest as it tests: a move of positions that waits for the next
  // frame must find its own there again (an offset move reads the device's rest[]).
  const bool restage = embed_pending && !offsets_pending;
  try {
    stage_rest(X, where);  // throws before anything but up_rest changes
  } catch (...) {
    if (restage) stage_rest(rest, where);
    throw;
  }
  // The rest volumes wait for their first use, as the CPU Deformer's (frame/rest_volume.h):
  // a plain frame does not read them. Where they might overflow they are summed, and
  // refused, now.
  const bool eager = !rest_volume_stays_finite(topo->lattice, topo->faces.rows(), X);
  RestVolumes vols;
  if (eager) {
    try {
      vols = measure_rest(X, where);
    } catch (...) {
      if (restage) stage_rest(rest, where);  // as above: the waiting move's positions again
      throw;
    }
  }
  embed_pending = true;
  offsets_pending = false;
  if (!defer) flush_embedding();
  {
    std::lock_guard<std::mutex> lock(rest_mutex);
    rest.swap(spare_rest);  // the positions stage_rest copied (spare_rest keeps the old buffer)
    rest_stale = false;
  }
  base.resize(0, 3);  // later offsets move from X
  volumes_of_base = false;
  rest_vols = eager ? std::make_shared<Lazy<RestVolumes>>(std::move(vols)) : std::make_shared<Lazy<RestVolumes>>();
  normals_ready = false;  // the rest normals are of the old positions
}

RowMatrixX3d VulkanDeformer::Impl::offset_positions(const Eigen::Ref<const RowMatrixX3d>& O) const {
  const std::int32_t* part = K > 1 ? topo->parts.vertex_part.data() : nullptr;
  RowMatrixX3d X(nv, 3);
  parallel_range(nv, 0, [&](Index b, Index e) {
    for (Index v = b; v < e; ++v) {
      const Index k = part ? Index(part[v]) : 0;
      for (int a = 0; a < 3; ++a) X(v, a) = base(v, a) + O(k, a);  // the CPU Deformer's sum
    }
  });
  return X;
}

const RowMatrixX3d& VulkanDeformer::Impl::rest_positions() const {
  std::lock_guard<std::mutex> lock(rest_mutex);
  if (rest_stale) {
    rest = offset_positions(offsets);
    rest_stale = false;
  }
  return rest;
}

void VulkanDeformer::Impl::offset_rest(const Eigen::Ref<const RowMatrixX3d>& O, const char* where) {
  const FrameTopology& c = *topo;  // lattice, parts, edges and policy: what no move changes
  VPFFD_CHECK(O.rows() == K, where, ": ", O.rows(), " offsets, expected one per part (", K,
              c.has_parts ? " parts)" : ": the deformer has no parts, so one for the whole mesh)");
  for (Index k = 0; k < O.rows(); ++k)
    VPFFD_CHECK(O.row(k).allFinite(), where, ": offset ", k, " (", O(k, 0), ", ", O(k, 1), ", ", O(k, 2),
                ") is not finite");
  const bool first = base.rows() == 0;
  if (first) {
    base = rest_positions();
    // Each part's box: base + o rounds monotonically in the base coordinate, so the
    // moved box's corners are the extremes of the moved vertices, and every test of a
    // move (stage_rest's, all intervals in each coordinate) holds for all vertices iff
    // it holds for the corners.
    base_box.resize(K, 6);
    for (int k = 0; k < K; ++k)
      for (int a = 0; a < 3; ++a) {
        base_box(k, a) = std::numeric_limits<double>::infinity();
        base_box(k, 3 + a) = -std::numeric_limits<double>::infinity();
      }
    const std::int32_t* part = K > 1 ? c.parts.vertex_part.data() : nullptr;
    for (Index v = 0; v < nv; ++v) {
      const Index k = part ? Index(part[v]) : 0;
      for (int a = 0; a < 3; ++a) {
        base_box(k, a) = std::min(base_box(k, a), base(v, a));
        base_box(k, 3 + a) = std::max(base_box(k, 3 + a), base(v, a));
      }
    }
  }
  // stage_rest's tests of the two corners of every part that has vertices.
  const Lattice& L = c.lattice;
  const bool refuse_outside = c.policy == OutsidePolicy::Error;
  const ParameterMap to_parameter(L);
  bool ok = true;
  for (int k = 0; k < K && ok; ++k) {
    if (!(base_box(k, 0) <= base_box(k, 3))) continue;  // a part without vertices
    for (int a = 0; a < 3; ++a)
      for (int corner = 0; corner < 2; ++corner) {
        const double x = base_box(k, 3 * corner + a) + O(k, a);
        if (L.periodic(a)) {
          // Wrapped into the box (always inside); the device's far limit.
          const double centre = 0.5 * (L.box_min[a] + L.box_max[a]);
          ok &= std::isfinite(x) && std::abs(x - centre) <= std::ldexp(1.0, 24) * (L.box_max[a] - L.box_min[a]);
          continue;
        }
        const double u = to_parameter.lo[a] + (x - to_parameter.box_min[a]) * to_parameter.k[a];
        ok &= accepted_parameters(L, a).contains(u);
        if (refuse_outside) ok &= accepted_box(L, a).contains(x);
      }
  }
  if (!ok) {
    RowMatrixX3d X = offset_positions(O);
    refuse_rest(X, where);
    if (first) base.resize(0, 3);
    throw InvalidInputError(std::string(where) + ": a vertex moves outside the lattice box");  // not reached
  }
  // Nothing below throws but Vulkan calls.
  const bool keep_volumes = K > 1 || c.closed();
  RestVolumes vols;
  bool eager = false;
  if (!keep_volumes) {
    // An open mesh's cone volume from the origin changes with a translation.
    RowMatrixX3d X = offset_positions(O);
    eager = !rest_volume_stays_finite(L, nf, X);
    if (eager) vols = measure_rest(X, where);
  }
  // A move of positions that still waits for its embedding has not reached rest[] on the
  // device: it runs first, alone (an offset move after set_rest_vertices, no frame between).
  if (embed_pending && !offsets_pending) flush_embedding();
  std::vector<double> o(3 * size_t(K));
  for (int k = 0; k < K; ++k)
    for (int a = 0; a < 3; ++a) o[3 * k + a] = O(k, a) / scale;  // scale: a power of two
  put_reals(up_offsets.mapped(), o.data(), o.size(), ff);
  embed_pending = true;
  offsets_pending = true;
  {
    std::lock_guard<std::mutex> lock(rest_mutex);
    offsets = O;
    rest_stale = true;
  }
  if (keep_volumes) {
    // The base's volumes: rest_vols are already theirs (the base was the rest mesh).
    volumes_of_base = true;
  } else {
    rest_vols = eager ? std::make_shared<Lazy<RestVolumes>>(std::move(vols)) : std::make_shared<Lazy<RestVolumes>>();
    volumes_of_base = false;
  }
  // Rest normals are unchanged by a translation (rest_normals.comp reads the base).
}

const Deformer& VulkanDeformer::Impl::synced_cpu() {
  std::lock_guard<std::mutex> lock(cpu_mutex);
  if (!host) host = std::make_unique<Deformer>(topo, plan_state);  // shares, embeds nothing
  if (cpu_stale) {
    host->set_rest_vertices(rest_positions());
    cpu_stale = false;
  }
  return *host;
}

const CorrectionOptions& VulkanDeformer::Impl::plan_options(const CorrectionOptions& opt,
                                                            CorrectionOptions& storage) const {
  if (!moved) return opt;
  storage = opt;
  for (PointConstraint& c : storage.constraints)
    if (c.vertex >= 0 && c.vertex < nv) {
      c.point = rest_positions().row(c.vertex).transpose();
      c.vertex = -1;
    }
  return storage;
}

// ---- public API ----------------------------------------------------------------

void VulkanDeformer::set_rest_vertices(const Eigen::Ref<const RowMatrixX3d>& X) {
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.frame_mutex);
  m.embed_rest(X, "set_rest_vertices", /*defer=*/true);
  m.moved = true;
  std::lock_guard<std::mutex> cpu_lock(m.cpu_mutex);
  m.cpu_stale = true;
}

void VulkanDeformer::set_rest_offsets(const Eigen::Ref<const RowMatrixX3d>& offsets) {
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.frame_mutex);
  m.offset_rest(offsets, "set_rest_offsets");
  m.moved = true;
  std::lock_guard<std::mutex> cpu_lock(m.cpu_mutex);
  m.cpu_stale = true;
}

RowMatrixX3d VulkanDeformer::rest_vertices() const {
  std::lock_guard<std::mutex> lock(impl_->frame_mutex);  // no move between the read and the copy
  return impl_->rest_positions();
}

double VulkanDeformer::rest_volume(bool allow_open) const {
  if (!allow_open) require_closed(impl_->topo->edges, "rest_volume");
  std::lock_guard<std::mutex> lock(impl_->frame_mutex);
  return impl_->rest_volumes().total;
}

bool VulkanDeformer::rest_volume_known() const {
  std::lock_guard<std::mutex> lock(impl_->frame_mutex);
  return impl_->rest_vols->known();
}

double VulkanDeformer::rest_volume_of(const Eigen::Ref<const RowMatrixX3d>& X) const {
  VPFFD_CHECK(X.rows() == impl_->nv, "rest_volume_of: ", X.rows(), " vertices, the mesh has ", impl_->nv);
  return impl_->measure_rest(X, "rest_volume_of").total;
}

}  // namespace vpffd::vulkan
