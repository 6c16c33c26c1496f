// VulkanDeformer set-up: the device buffers, the mesh's faces and adjacency in the CPU
// Deformer's processing order (the device's vertex slots), the basis tables, and the
// pipelines of both precisions; the rest positions are then embedded on the device
// (rest_embedding.cpp).
//
// Periodic lattices (lattice/periodic.h): the device evaluates the extended lattice (NE
// control points, the host expands the user's N distinct ones each frame: one float32
// rounding of each, as for any control point) and solves for the distinct ones. The
// tie map goes up once (bTies): per extended point its distinct one (gather, solve and
// normals read offsets through it: a copy, the shift seam's constant belongs to
// positions only), and per distinct point its extended copies (combine.comp folds the
// coefficients: each distinct point sums the tiles of all its copies, in a fixed
// order). The seams are a specialisation constant; embed.comp wraps the rest positions
// into the box and keeps per slot what the wrap did (bSeam).
//
// Parts (deformer_impl.h): the processing faces are grouped by part; bParts holds the
// K + 1 face offsets and each slot's part; the cell sort's keys and tables grow to
// K x NE keys, the tiles' bound to V / 64 + min(V, K cells), alpha to K rows of N.

#include <array>
#include <cstdlib>

#include "deformer_impl.h"
#include "vpffd/ffd/basis_matrix.h"
#include "vpffd/shaders/spirv.h"

namespace vpffd::vulkan {

using detail::get_real;
using detail::groups_for;
using detail::ms_since;
using detail::put_reals;

void VulkanDeformer::Impl::create_pipelines(const std::array<std::int32_t, 16>& spec) {
  detail::create_compute_pipelines(d, buf, kBindings, sizeof(Push), spec.data(), std::uint32_t(spec.size()),
                                   ff ? kShadersFF : kShaders64, kPipes, pl);
}

void VulkanDeformer::Impl::build(const std::string& selector, Precision wanted) {
  dev = detail::open_device(selector);
  d = dev->handle;
  if (wanted == Precision::Float64 && !dev->info.float64)
    throw BackendUnavailableError("vulkan: device " + dev->info.name +
                                  " has no shaderFloat64: use precision 'float-float' or 'auto'");
  precision = wanted == Precision::Auto ? (dev->info.float64 ? Precision::Float64 : Precision::FloatFloat) : wanted;
  ff = precision == Precision::FloatFloat;
  const FrameTopology& c = *topo;
  const RestState& s = *plan_state;
  const Lattice& L = c.lattice;
  const BasisTables& T = c.tables;
  // The device's vertex slots, for the deformer's life: the CPU frame's processing
  // order (by cell) of the first rest mesh, with its faces and adjacency. The device
  // sorts the slots by cell again after every move (rest_embedding.cpp); at
  // construction that stable sort leaves them in this order.
  const std::vector<std::int32_t>& order = *s.order;
  const RowMatrixX3i& Fs = processing_faces(c, s);
  const VertexFaces& adj = processing_adjacency(c, s);
  nv = c.n_vertices;
  nf = c.faces.rows();
  N = c.ties.n_distinct;
  NE = L.n_control_points();
  const Ties& ties = c.ties;
  origin = c.origin;
  {
    const double half = 0.5 * (L.box_max - L.box_min).norm();
    scale = std::isfinite(half) && half > 0 ? std::exp2(std::round(std::log2(half))) : 1.0;
  }
  const auto dims = L.dims();
  KKK = T.order[0] * T.order[1] * T.order[2];
  K = c.parts.count;
  // Not bad input, a limit of this backend: "auto" then falls back to the CPU.
  if (K > MAX_DEVICE_PARTS)
    throw BackendUnavailableError(vpffd::detail::concat("VulkanDeformer: ", K, " parts; the Vulkan backend keeps at most ",
                                                  MAX_DEVICE_PARTS, " parts (its solve factors the K x K system in "
                                                  "one workgroup); use a CPU backend"));
  // The sort keys part * NE + cell, and the K x N coefficient rows, in 32-bit indices.
  if (Index(K) * NE + 1 >= (Index(1) << 31) || Index(K) * N >= (Index(1) << 31))
    throw InvalidInputError("VulkanDeformer: too many parts for this lattice (parts x control points over 2^31)");
  if (nv * 3 >= (Index(1) << 31) || nf * 3 >= (Index(1) << 31))
    throw InvalidInputError("VulkanDeformer: the mesh is too large for 32-bit device indices");

  std::vector<float> poly;
  std::array<std::int32_t, 3> poly_off{};
  for (int a = 0; a < 3; ++a) {
    poly_off[a] = static_cast<std::int32_t>(poly.size());
    for (double x : T.poly[a].coef) poly.push_back(static_cast<float>(x));
  }
  // normals.comp's table in reals: the power forms, then the derivative scales
  // d tau / d y = (1 / span width) (du / dx) scale per axis and span (the shader finds
  // them from the sizes).
  std::vector<double> nrm_tab;
  {
    const Vector3d du_dx = parameter_scale(L);
    for (int a = 0; a < 3; ++a) nrm_tab.insert(nrm_tab.end(), T.poly[a].coef.begin(), T.poly[a].coef.end());
    for (int a = 0; a < 3; ++a)
      for (double w : T.poly[a].inv_width) nrm_tab.push_back(w * du_dx[a] * scale);
  }
  std::vector<double> nrm_tab_dev(nrm_tab.size());  // 8 bytes per real in either precision
  put_reals(nrm_tab_dev.data(), nrm_tab.data(), nrm_tab.size(), ff);

  // Tiles: a cell with c vertices has ceil(c / 64) <= c / 64 + 1 of them, and at most
  // min(V, cells) cells have vertices: whatever the rest positions, NTILE below is
  // enough, so it stays a specialization constant and moves need no new pipelines.
  {
    const Index cells = Index(dims[0] - T.order[0] + 1) * (dims[1] - T.order[1] + 1) * (dims[2] - T.order[2] + 1);
    // With parts the runs are per (part, cell) key: at most min(V, K cells) of them.
    n_tiles = (nv + kTile - 1) / kTile + std::min(nv, Index(K) * cells);
  }
  if (n_tiles * KKK >= (Index(1) << 31) || 4 * nv + 2 * NE >= (Index(1) << 31))
    throw InvalidInputError("VulkanDeformer: the mesh is too large for 32-bit device indices");
  // The cell sort: keys (part * NE + first control point index) below K NE, 8 bits
  // per pass, an even number of passes so that the sorted pairs end in the first array.
  const Index n_keys = Index(K) * NE;
  {
    int bits = 1;
    while ((Index(1) << bits) < n_keys) ++bits;
    sort_passes = static_cast<std::uint32_t>(2 * ((bits + 15) / 16));
    sort_blocks = static_cast<std::uint32_t>((nv + VPFFD_SORT_BLOCK - 1) / VPFFD_SORT_BLOCK);
    if (sort_blocks > 65535)
      throw InvalidInputError("VulkanDeformer: the mesh is too large for the device cell sort (over 67M vertices)");
  }
  // The embedding table after the rest positions (layout.h EM_*): u = u0 + y du per
  // axis for y = (x - origin) / scale, then the knots.
  std::vector<double> em(EM_KNOTS);
  for (int a = 0; a < 3; ++a) {
    const double lo = L.domain_lo(a), hi = L.domain_hi(a), k = (hi - lo) / (L.box_max[a] - L.box_min[a]);
    em[EM_U0 + a] = lo + (origin[a] - L.box_min[a]) * k;
    em[EM_DU + a] = scale * k;
    // The box for the wrap of periodic axes (embed.comp), as wrap_point uses it.
    em[EM_LO + a] = (L.box_min[a] - origin[a]) / scale;
    em[EM_HI + a] = (L.box_max[a] - origin[a]) / scale;
    em[EM_EXT + a] = (L.box_max[a] - L.box_min[a]) / scale;
    em[EM_MID + a] = (L.box_min[a] + L.box_max[a] - 2 * origin[a]) / scale;
  }
  for (int a = 0; a < 3; ++a) {
    VPFFD_CHECK(L.knots[a].size() == size_t(dims[a] + T.order[a]), "VulkanDeformer: knot vector ", a, " has ",
                L.knots[a].size(), " entries, expected ", dims[a] + T.order[a]);
    em.insert(em.end(), L.knots[a].begin(), L.knots[a].end());
  }
  // set_rest_offsets' translations go behind the knots (zero until its first move).
  offsets_at = 3 * nv + Index(em.size());
  em.resize(em.size() + 3 * size_t(K), 0.0);
  std::vector<double> em_dev(em.size());
  put_reals(em_dev.data(), em.data(), em.size(), ff);

  g_vert = groups_for(nv, kMaxGroups);
  g_face = groups_for(nf, kMaxGroups);
  g_cp = groups_for(NE, 256);
  g_tile = static_cast<std::uint32_t>(std::min<Index>(n_tiles, 65535));
  // A GPU sums each coefficient row with a workgroup's lanes; a CPU device (lavapipe)
  // runs a workgroup's invocations in turn, so one lane per row there (combine.comp).
  // VPFFD_VULKAN_ROW_LANES overrides (the tests take every path on lavapipe).
  row_lanes = dev->info.type == "cpu" ? 1 : VPFFD_TILE;
  if (const char* e = std::getenv("VPFFD_VULKAN_ROW_LANES"); e && *e) {
    char* end = nullptr;
    const long v = std::strtol(e, &end, 10);
    if (*end || v < 1 || v > VPFFD_TILE || (v & (v - 1)))
      throw InvalidInputError(vpffd::detail::concat("VPFFD_VULKAN_ROW_LANES: expected a power of two from 1 to ",
                                                    VPFFD_TILE, ", got '", e, "'"));
    row_lanes = static_cast<int>(v);
  }
  const Index rows_per_group = VPFFD_TILE / row_lanes;
  g_rows = static_cast<std::uint32_t>(std::clamp<Index>((Index(K) * N + rows_per_group - 1) / rows_per_group, 1, 65535));
  const size_t scan_size = std::max<size_t>(size_t(VPFFD_SORT_DIGITS) * sort_blocks, size_t(n_keys) + 1);

  using B = detail::Buffer;
  auto mk = [&](Buf i, size_t bytes, const char* what) { buf[i] = B(*dev, bytes, B::DeviceLocal, what); };
  mk(bP, 12 * NE, "control points");
  mk(bX, 12 * nv, "vertices");
  if (const char* e = std::getenv("VPFFD_VULKAN_READBACK"); e && *e) {
    const std::string v = e;
    if (v != "device" && v != "host")
      throw InvalidInputError("VPFFD_VULKAN_READBACK: expected 'device' (the caller's vertex order made on the "
                              "device) or 'host' (reordered on the host), got '" + v + "'");
    place_on_device = v == "device";
  }
  // The vertices in the caller's order (place.comp); the normals' region is added by
  // the first frame that asks for normals (prepare_normals).
  mk(bPlaced, place_on_device ? 3 * placed_real() * nv : 16, "vertices (caller's order)");
  x_good = B(*dev, 12 * nv, B::DeviceLocal, "vertices of the last good frame");
  mk(bF, 12 * nf, "faces");
  mk(bAdjPtr, 4 * adj.indptr.size(), "adjacency");
  mk(bAdj, 4 * adj.faces.size(), "adjacency");
  mk(bSpan, 12 * nv, "spans");
  mk(bTau, 12 * nv, "parameters");
  mk(bPoly, 4 * poly.size(), "basis table");
  mk(bTiles, 16 * n_tiles, "tiles");
  mk(bPartial, 8 * size_t(n_tiles) * KKK, "tile partials");
  mk(bTileVol, 8 * n_tiles, "tile volumes");
  mk(bScan, 4 * scan_size, "cell sort counts");
  mk(bRest, 8 * (3 * nv + em.size()), "rest positions");
  mk(bSlotVertex, 8 * size_t(nv), "slot vertices");
  mk(bSort, 4 * (4 * nv + 2 * n_keys), "cell sort");
  up_rest = B(*dev, 24 * nv, B::Upload, "rest positions (upload)");
  up_offsets = B(*dev, 24 * size_t(K), B::Upload, "rest offsets (upload)");
  mk(bAlpha, 8 * size_t(K) * N, "coefficients");
  mk(bInvW, 8 * N, "inverse weights");
  mk(bDelta, 32 * N, "offsets");
  mk(bStats, 8 * ST_SIZE, "frame results");
  mk(bRed, 16 * kMaxGroups, "volume partials");
  // Placeholders until a frame asks for normals (prepare_normals): 36 bytes per vertex
  // that a caller who never asks does not pay.
  mk(bNrm0, 16, "rest normals");
  mk(bNrm, 16, "normals");
  mk(bNrmTab, 8 * nrm_tab.size(), "normals basis table");
  // Periodic lattices: the tie map (common.glsl TIE_*) and the per-slot seam data;
  // placeholders without (the shaders do not read them then).
  std::vector<std::int32_t> tie_map;
  if (!ties.identity) {
    tie_map.assign(ties.source.begin(), ties.source.end());
    std::vector<std::int32_t> ptr(N + 1, 0), list(NE);
    for (std::int32_t s : ties.source) ++ptr[s + 1];
    for (Index s = 0; s < N; ++s) ptr[s + 1] += ptr[s];
    std::vector<std::int32_t> fill(ptr.begin(), ptr.end() - 1);
    for (Index r = 0; r < NE; ++r) list[fill[ties.source[r]]++] = static_cast<std::int32_t>(r);  // r ascending
    tie_map.insert(tie_map.end(), ptr.begin(), ptr.end());
    tie_map.insert(tie_map.end(), list.begin(), list.end());
  }
  mk(bTies, std::max<size_t>(16, 4 * tie_map.size()), "periodic ties");
  bool seam_data = false;
  for (int a = 0; a < 3; ++a) seam_data |= L.seam[a] == Seam::Shift || L.seam[a] == Seam::Twist;
  mk(bSeam, seam_data ? 16 * size_t(nv) : 16, "seam translations");
  // Parts: each part's face range in the processing faces (grouped by part by the CPU
  // Deformer, part_face_start) and the part of every slot (parts[] of common.glsl).
  std::vector<std::int32_t> part_map;
  if (K > 1) {
    const std::vector<std::int32_t>& vp = c.parts.vertex_part;
    for (Index f : c.face_start) part_map.push_back(static_cast<std::int32_t>(f));
    for (Index i = 0; i < nv; ++i) part_map.push_back(vp[order[i]]);
    // A volume pass: each part in the same number of workgroups, all within `red`'s slot.
    g_part = std::max<std::uint32_t>(1, std::min<std::uint32_t>(g_face, kMaxGroups / std::uint32_t(K)));
  }
  mk(bParts, std::max<size_t>(16, 4 * part_map.size()), "parts");
  reserve(bFrame, &up_frame, 8 * FR_RHS, "frame parameters");
  reserve(bConsI, &up_cons_i, 4 * (CI_BASE + N + 1), "constraints");
  reserve(bConsD, &up_cons_d, 8, "constraints");
  reserve(bWork, nullptr, 8 * work_size(0), "solve scratch");
  up_P = B(*dev, 12 * NE, B::Upload, "control points (upload)");
  up_invw = B(*dev, 8 * N, B::Upload, "inverse weights (upload)");
  up_delta = B(*dev, 24 * N, B::Upload, "offsets (upload)");
  rb_delta = B(*dev, 24 * N, B::Readback, "offsets (read-back)");
  rb_stats = B(*dev, 8 * ST_SIZE, B::Readback, "frame results (read-back)");
  rb_red = B(*dev, 16 * kMaxGroups, B::Readback, "volume partials (read-back)");

  cmd_pool = detail::create_command_pool(*dev);
  cmd = detail::allocate_command_buffer(d, cmd_pool.get());
  fence = detail::create_fence(d);
  queries = detail::create_timestamp_queries(*dev, kReadbackQuery + 2);

  // One-time upload through temporary staging buffers, one submission.
  std::vector<B> staging;
  begin();
  auto put = [&](Buf i, const void* data, size_t bytes) {
    if (bytes == 0) return;
    staging.emplace_back(*dev, bytes, B::Upload, "staging");
    std::memcpy(staging.back().mapped(), data, bytes);
    copy(staging.back(), buf[i], bytes);
  };
  put(bF, Fs.data(), 12 * size_t(nf));
  put(bAdjPtr, adj.indptr.data(), 4 * adj.indptr.size());
  put(bAdj, adj.faces.data(), 4 * adj.faces.size());
  put(bPoly, poly.data(), 4 * poly.size());
  put(bNrmTab, nrm_tab_dev.data(), 8 * nrm_tab_dev.size());
  put(bTies, tie_map.data(), 4 * tie_map.size());
  put(bParts, part_map.data(), 4 * part_map.size());
  {
    // Each slot's caller vertex, then each caller vertex's slot (place.comp's gather).
    std::vector<std::int32_t> both(order.begin(), order.end());
    both.resize(2 * size_t(nv));
    for (Index i = 0; i < nv; ++i) both[nv + order[i]] = static_cast<std::int32_t>(i);
    put(bSlotVertex, both.data(), 4 * both.size());
  }
  {
    // place.comp's units before any frame (vertices() reads back the rest positions).
    std::vector<double> fr(FR_RHS, 0.0), fr_dev(FR_RHS);
    put_units(fr.data());
    put_reals(fr_dev.data(), fr.data(), fr.size(), ff);
    put(bFrame, fr_dev.data(), 8 * fr_dev.size());
  }
  // The table goes behind the rest positions (their place is filled per move).
  staging.emplace_back(*dev, 8 * em_dev.size(), B::Upload, "staging");
  std::memcpy(staging.back().mapped(), em_dev.data(), 8 * em_dev.size());
  copy(cmd, staging.back(), buf[bRest], 8 * em_dev.size(), 0, 24 * nv);
  submit_and_wait();

  static_assert(int(Seam::None) == SEAM_NONE && int(Seam::Shift) == SEAM_SHIFT && int(Seam::Closed) == SEAM_CLOSED &&
                    int(Seam::Twist) == SEAM_TWIST,
                "the shaders' seam codes are lattice.h's");
  std::int32_t seams = 0, kinds = 0;
  for (int a = 0; a < 3; ++a) {
    seams |= static_cast<std::int32_t>(L.seam[a]) << (2 * a);
    if (L.seam[a] != Seam::None) kinds |= 1 << static_cast<int>(L.seam[a]);
  }
  const std::array<std::int32_t, 16> spec = {T.order[0], T.order[1], T.order[2],
                                              dims[0], dims[1], dims[2],
                                              static_cast<std::int32_t>(nv), static_cast<std::int32_t>(nf),
                                              static_cast<std::int32_t>(n_tiles), poly_off[1], poly_off[2],
                                              ties.identity ? 0 : static_cast<std::int32_t>(N), seams, kinds, K,
                                              row_lanes};
  create_pipelines(spec);

  // The construction's rest mesh goes through the same device embedding as every
  // move: one code path, so the static and moved frames cannot drift apart.
  slot = order;
  record_embedding();
  embed_rest(*s.V, "VulkanDeformer", /*defer=*/false);

  // No constraints until a frame has some: every frame's solve reads the block.
  begin();
  update_constraints({}, VectorXd::Ones(N));
  submit_and_wait();
}

}  // namespace vpffd::vulkan
