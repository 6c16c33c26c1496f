// VulkanDeformer set-up: the device data of the CPU Deformer's embedding (cell order,
// tiles, combine lists), uploaded once, and the pipelines of both precisions.

#include <array>

#include "deformer_impl.h"
#include "vpffd/ffd/basis_matrix.h"
#include "vpffd/shaders/spirv.h"

namespace vpffd::vulkan {

using detail::get_real;
using detail::groups_for;
using detail::ms_since;
using detail::put_reals;

void VulkanDeformer::Impl::create_pipelines(const std::array<std::int32_t, 11>& spec) {
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
  const Deformer& c = *cpu;
  const Lattice& L = c.lattice();
  const BasisTables& T = c.tables();
  // The CPU Deformer's processing order (cells), faces and adjacency: a cell's
  // vertices share their K^3 control points, which the tiles of coef.comp reduce in
  // shared memory.
  const std::vector<std::int32_t>& order = c.processing_order();
  const Embedding& E = c.processing_embedding();
  const RowMatrixX3i& Fs = c.processing_faces();
  const VertexFaces& adj = c.processing_adjacency();
  nv = c.n_vertices();
  nf = c.n_faces();
  N = c.n_control_points();
  origin = c.origin();
  {
    const double half = 0.5 * (L.box_max - L.box_min).norm();
    scale = std::isfinite(half) && half > 0 ? std::exp2(std::round(std::log2(half))) : 1.0;
  }
  const auto dims = L.dims();
  KKK = T.order[0] * T.order[1] * T.order[2];
  if (nv * 3 >= (Index(1) << 31) || nf * 3 >= (Index(1) << 31))
    throw InvalidInputError("VulkanDeformer: the mesh is too large for 32-bit device indices");

  std::vector<std::int32_t> span(3 * nv), cell(nv);
  std::vector<float> tau(3 * nv), X0(3 * nv);
  const RowMatrixX3d& V = c.rest_vertices();
  for (Index i = 0; i < nv; ++i) {
    cell[i] = vpffd::detail::cell_index(T, E, i);
    for (int a = 0; a < 3; ++a) {
      span[3 * i + a] = E.span[a][i] - T.poly[a].degree;
      tau[3 * i + a] = static_cast<float>(E.tau[a][i]);
      X0[3 * i + a] = static_cast<float>((V(order[i], a) - origin[a]) / scale);
    }
  }
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

  // Tiles and, per control point, the partials (tile * K^3 + local) that touch it.
  std::vector<std::int32_t> tiles;
  for (Index i = 0; i < nv;) {
    Index j = i;
    while (j < nv && j - i < kTile && cell[j] == cell[i]) ++j;
    tiles.insert(tiles.end(), {static_cast<std::int32_t>(i), static_cast<std::int32_t>(j - i), cell[i], 0});
    i = j;
  }
  n_tiles = static_cast<Index>(tiles.size() / 4);
  if (n_tiles * KKK >= (Index(1) << 31))
    throw InvalidInputError("VulkanDeformer: the mesh is too large for 32-bit device indices");
  std::vector<std::int32_t> comb_ptr(N + 1, 0), comb;
  {
    auto each = [&](auto&& f) {
      for (Index t = 0; t < n_tiles; ++t) {
        const Index base = tiles[4 * t + 2];
        int o = 0;
        for (int i = 0; i < T.order[0]; ++i)
          for (int j = 0; j < T.order[1]; ++j)
            for (int k = 0; k < T.order[2]; ++k, ++o)
              f(base + (Index(i) * dims[1] + j) * dims[2] + k, static_cast<std::int32_t>(t * KKK + o));
      }
    };
    each([&](Index cp, std::int32_t) { ++comb_ptr[cp + 1]; });
    for (Index k = 0; k < N; ++k) comb_ptr[k + 1] += comb_ptr[k];
    comb.resize(comb_ptr[N]);
    std::vector<std::int32_t> fill(comb_ptr.begin(), comb_ptr.end() - 1);
    each([&](Index cp, std::int32_t idx) { comb[fill[cp]++] = idx; });
  }

  g_vert = groups_for(nv, kMaxGroups);
  g_face = groups_for(nf, kMaxGroups);
  g_cp = groups_for(N, 256);
  g_tile = static_cast<std::uint32_t>(std::min<Index>(n_tiles, 65535));

  using B = detail::Buffer;
  auto mk = [&](Buf i, size_t bytes, const char* what) { buf[i] = B(*dev, bytes, B::DeviceLocal, what); };
  mk(bP, 12 * N, "control points");
  mk(bX, 12 * nv, "vertices");
  x_good = B(*dev, 12 * nv, B::DeviceLocal, "vertices of the last good frame");
  mk(bF, 12 * nf, "faces");
  mk(bAdjPtr, 4 * adj.indptr.size(), "adjacency");
  mk(bAdj, 4 * adj.faces.size(), "adjacency");
  mk(bSpan, 4 * span.size(), "spans");
  mk(bTau, 4 * tau.size(), "parameters");
  mk(bPoly, 4 * poly.size(), "basis table");
  mk(bTiles, 4 * tiles.size(), "tiles");
  mk(bPartial, 8 * size_t(n_tiles) * KKK, "tile partials");
  mk(bTileVol, 8 * n_tiles, "tile volumes");
  mk(bCombPtr, 4 * comb_ptr.size(), "combine lists");
  mk(bComb, 4 * comb.size(), "combine lists");
  mk(bAlpha, 8 * N, "coefficients");
  mk(bInvW, 8 * N, "inverse weights");
  mk(bDelta, 32 * N, "offsets");
  mk(bStats, 8 * ST_SIZE, "frame results");
  mk(bRed, 16 * kMaxGroups, "volume partials");
  // Placeholders until a frame asks for normals (prepare_normals): 36 bytes per vertex
  // that a caller who never asks does not pay.
  mk(bNrm0, 16, "rest normals");
  mk(bNrm, 16, "normals");
  mk(bNrmTab, 8 * nrm_tab.size(), "normals basis table");
  reserve(bFrame, &up_frame, 8 * FR_RHS, "frame parameters");
  reserve(bConsI, &up_cons_i, 4 * (CI_BASE + N + 1), "constraints");
  reserve(bConsD, &up_cons_d, 8, "constraints");
  reserve(bWork, nullptr, 8 * 6, "solve scratch");
  up_P = B(*dev, 12 * N, B::Upload, "control points (upload)");
  up_invw = B(*dev, 8 * N, B::Upload, "inverse weights (upload)");
  up_delta = B(*dev, 24 * N, B::Upload, "offsets (upload)");
  rb_delta = B(*dev, 24 * N, B::Readback, "offsets (read-back)");
  rb_stats = B(*dev, 8 * ST_SIZE, B::Readback, "frame results (read-back)");
  rb_red = B(*dev, 16 * kMaxGroups, B::Readback, "volume partials (read-back)");

  VkCommandPoolCreateInfo cpi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  cpi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  cpi.queueFamilyIndex = dev->family;
  VkCommandPool cmd_pool_h = VK_NULL_HANDLE;
  detail::check(vkCreateCommandPool(d, &cpi, nullptr, &cmd_pool_h), "vkCreateCommandPool");
  cmd_pool.adopt(d, cmd_pool_h, vkDestroyCommandPool);
  VkCommandBufferAllocateInfo cai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  cai.commandPool = cmd_pool.get();
  cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cai.commandBufferCount = 1;
  detail::check(vkAllocateCommandBuffers(d, &cai, &cmd), "vkAllocateCommandBuffers");
  VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VkFence fence_h = VK_NULL_HANDLE;
  detail::check(vkCreateFence(d, &fi, nullptr, &fence_h), "vkCreateFence");
  fence.adopt(d, fence_h, vkDestroyFence);
  if (dev->timestamps) {
    VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
    qi.queryCount = kQueries;
    VkQueryPool queries_h = VK_NULL_HANDLE;
    detail::check(vkCreateQueryPool(d, &qi, nullptr, &queries_h), "vkCreateQueryPool");
    queries.adopt(d, queries_h, vkDestroyQueryPool);
  }

  // One-time upload through temporary staging buffers, one submission.
  std::vector<B> staging;
  begin();
  auto put = [&](Buf i, const void* data, size_t bytes) {
    if (bytes == 0) return;
    staging.emplace_back(*dev, bytes, B::Upload, "staging");
    std::memcpy(staging.back().mapped(), data, bytes);
    copy(staging.back(), buf[i], bytes);
  };
  put(bX, X0.data(), 4 * X0.size());
  put(bF, Fs.data(), 12 * size_t(nf));
  put(bAdjPtr, adj.indptr.data(), 4 * adj.indptr.size());
  put(bAdj, adj.faces.data(), 4 * adj.faces.size());
  put(bSpan, span.data(), 4 * span.size());
  put(bTau, tau.data(), 4 * tau.size());
  put(bPoly, poly.data(), 4 * poly.size());
  put(bNrmTab, nrm_tab_dev.data(), 8 * nrm_tab_dev.size());
  put(bTiles, tiles.data(), 4 * tiles.size());
  put(bCombPtr, comb_ptr.data(), 4 * comb_ptr.size());
  put(bComb, comb.data(), 4 * comb.size());
  submit_and_wait();

  const std::array<std::int32_t, 11> spec = {T.order[0], T.order[1], T.order[2],
                                              dims[0], dims[1], dims[2],
                                              static_cast<std::int32_t>(nv), static_cast<std::int32_t>(nf),
                                              static_cast<std::int32_t>(n_tiles), poly_off[1], poly_off[2]};
  create_pipelines(spec);

  // No constraints until a frame has some: every frame's solve reads the block.
  begin();
  update_constraints({}, VectorXd::Ones(N));
  submit_and_wait();
}

}  // namespace vpffd::vulkan
