// The point constraints' block on the device (solve.comp): the rows' control points
// and basis values, G = R W^-1 R^T and its inverse, with the CPU backend's checks.
// Uploaded only when the constraint sources or the weights change. On a periodic
// lattice the rows are folded onto the distinct control points (the unknowns), while
// each row keeps its first extended index (solve.comp walks its K^3 block).

#include <Eigen/Eigenvalues>

#include "deformer_impl.h"

namespace vpffd::vulkan {

using detail::get_real;
using detail::groups_for;
using detail::ms_since;
using detail::put_reals;

bool VulkanDeformer::Impl::update_constraints(const std::vector<SparseVec>& rows, const VectorXd& inv_weight) {
  const Index nc = static_cast<Index>(rows.size());
  std::vector<std::int32_t> index;
  std::vector<double> value;
  index.reserve(nc * KKK);
  value.reserve(nc * KKK);
  for (const SparseVec& r : rows) {
    index.insert(index.end(), r.index.begin(), r.index.end());
    value.insert(value.end(), r.value.begin(), r.value.end());
  }
  // Without constraints the block does not depend on the weights.
  if (cons.valid && cons.index == index && cons.value == value &&
      (nc == 0 || (cons.inv_weight.size() == inv_weight.size() && cons.inv_weight == inv_weight)))
    return false;

  // The rows' entries name extended control points; the unknowns are the distinct ones
  // (periodic ties, correction/tied_solve.h): an entry counts for the point it copies.
  const Ties& ties = topo->ties;
  std::vector<std::int32_t> dist(index);
  if (!ties.identity)
    for (std::int32_t& c : dist) c = ties.source[c];
  // Per control point, its entries s * KKK + o among the rows (s ascending: a fixed order).
  std::vector<std::int32_t> ptr(N + 1, 0), entry(index.size());
  for (std::int32_t c : dist) ++ptr[c + 1];
  for (Index c = 0; c < N; ++c) ptr[c + 1] += ptr[c];
  {
    std::vector<std::int32_t> fill(ptr.begin(), ptr.end() - 1);
    for (size_t e = 0; e < dist.size(); ++e) entry[fill[dist[e]]++] = static_cast<std::int32_t>(e);
  }
  // C = R W^-1 R^T through those lists: only pairs of rows that share a control point.
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(nc, nc);
  for (Index c = 0; c < N; ++c)
    for (std::int32_t p = ptr[c]; p < ptr[c + 1]; ++p)
      for (std::int32_t q = ptr[c]; q < ptr[c + 1]; ++q)
        C(entry[p] / KKK, entry[q] / KKK) += value[entry[p]] * inv_weight[c] * value[entry[q]];

  // The CPU backend's checks of the constraint rows (solve.h); the volume row's are on
  // the device. A failure here is answered by the CPU backend's own error.
  bool bad = false;
  const double max_iw = inv_weight.size() ? inv_weight.maxCoeff() : 1.0;
  for (Index s = 0; s < nc && !bad; ++s) {
    // The squared norm of the (folded) row: entries at one distinct point add first.
    double scale = 0;
    for (int o = 0; o < KKK; ++o) {
      const size_t e = size_t(s) * KKK + o;
      bool first = true;
      for (int q = 0; q < o && first; ++q) first = dist[size_t(s) * KKK + q] != dist[e];
      if (!first) continue;
      double v = 0;
      for (int q = o; q < KKK; ++q)
        if (dist[size_t(s) * KKK + q] == dist[e]) v += value[size_t(s) * KKK + q];
      scale += v * v;
    }
    bad = !(C(s, s) > 1e-300) || !(C(s, s) > 1e-24 * scale * max_iw);
  }
  double hi = 1.0;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(nc, nc);
  if (!bad && nc > 0) {
    const Eigen::VectorXd dg = C.diagonal().cwiseSqrt().cwiseInverse();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(dg.asDiagonal() * C * dg.asDiagonal());
    const double lo = eig.eigenvalues().minCoeff();
    hi = std::max(1.0, eig.eigenvalues().maxCoeff());
    bad = !(lo > 1e-12 * eig.eigenvalues().maxCoeff());
    if (!bad)
      H = dg.asDiagonal() * eig.eigenvectors() * eig.eigenvalues().cwiseInverse().asDiagonal() *
          eig.eigenvectors().transpose() * dg.asDiagonal();
  }

  const size_t ci_size = CI_BASE + nc + (N + 1) + index.size();
  const size_t cd_size = std::max<size_t>(1, value.size() + 2 * size_t(nc) * nc);
  reserve(bConsI, &up_cons_i, 4 * ci_size, "constraints");
  reserve(bConsD, &up_cons_d, 8 * cd_size, "constraints");
  reserve(bWork, nullptr, 8 * work_size(size_t(nc)), "solve scratch");
  std::int32_t* ci = static_cast<std::int32_t*>(up_cons_i.mapped());
  std::fill(ci, ci + CI_BASE, 0);
  ci[CI_NC] = static_cast<std::int32_t>(nc);
  ci[CI_PTR] = static_cast<std::int32_t>(CI_BASE + nc);
  ci[CI_IDX] = static_cast<std::int32_t>(CI_BASE + nc + N + 1);
  ci[CI_G] = static_cast<std::int32_t>(value.size());
  ci[CI_H] = static_cast<std::int32_t>(value.size() + size_t(nc) * nc);
  for (Index s = 0; s < nc; ++s) ci[CI_BASE + s] = index[s * KKK];
  std::copy(ptr.begin(), ptr.end(), ci + ci[CI_PTR]);
  std::copy(entry.begin(), entry.end(), ci + ci[CI_IDX]);
  std::vector<double> cd(cd_size, 0.0);
  std::copy(value.begin(), value.end(), cd.begin());
  for (Index p = 0; p < nc; ++p)
    for (Index q = 0; q < nc; ++q) {
      cd[ci[CI_G] + p * nc + q] = C(p, q);
      cd[ci[CI_H] + p * nc + q] = H(p, q);
    }
  put_reals(up_cons_d.mapped(), cd.data(), cd_size, ff);
  copy(up_cons_i, buf[bConsI], 4 * ci_size);
  copy(up_cons_d, buf[bConsD], 8 * cd_size);

  cons.valid = true;
  cons.index = std::move(index);
  cons.value = std::move(value);
  cons.inv_weight = inv_weight;
  cons.bad = bad;
  cons.hi = hi;
  return true;
}

}  // namespace vpffd::vulkan
