// Foot-point search: a dense tessellation of the limit surface in a hashed uniform
// grid gives, per point, the patches of its nearest samples; projected Newton in
// those patches (in order of distance) finds an exact foot point. A solution that
// stops on a patch's border (the true one lies across it) has a tangential residual
// and is passed over for the next patch.

#include "foot_search.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <Eigen/Dense>

#include "vpffd/core/parallel.h"

namespace vpffd::subdiv {

namespace {

// Samples per patch edge: 5 x 5 on a quad, 15 on a triangle.
constexpr int kSamples = 5;

void project_domain(bool tri, double& u, double& v) {
  u = std::clamp(u, 0.0, 1.0);
  v = std::clamp(v, 0.0, 1.0);
  if (tri && u + v > 1) {
    // Closest point of the hypotenuse u + v = 1, then back into [0, 1]^2.
    const double e = 0.5 * (u + v - 1);
    u = std::clamp(u - e, 0.0, 1.0);
    v = 1 - u;
  }
}

double tangential(const Vector3d& r, const Vector3d& du, const Vector3d& dv) {
  const Vector3d c = du.cross(dv);
  const double len = c.norm();
  if (!(len > 0)) return r.norm();
  const Vector3d n = c / len;
  return (r - r.dot(n) * n).norm();
}

struct Sample {
  Vector3d x;
  std::int32_t patch;
  float u, v;
};

/// Samples in a hashed uniform grid: (cell key, sample) sorted by key.
class SampleGrid {
 public:
  SampleGrid(const LimitSurface& s, int threads) {
    const int np = s.n_patches();
    std::vector<std::pair<double, double>> uv;
    for (int i = 0; i < kSamples; ++i)
      for (int j = 0; j < kSamples; ++j) {
        if (s.triangular(0)) {
          if (i + j > kSamples - 1) continue;
          uv.emplace_back((i + 1.0 / 3) / kSamples, (j + 1.0 / 3) / kSamples);
        } else {
          uv.emplace_back((i + 0.5) / kSamples, (j + 0.5) / kSamples);
        }
      }
    const size_t per = uv.size();
    samples_.resize(size_t(np) * per);
    std::vector<double> area(np);
    // Each patch is dozens of evaluations: parallel far below kParallelMin items.
    parallel_items(np, Index(np) * Index(per) * 64, threads, [&](Index k) {
      {
        double a = 0;
        for (size_t q = 0; q < per; ++q) {
          const LimitPoint L = s.evaluate(int(k), uv[q].first, uv[q].second);
          samples_[k * per + q] = {L.p, std::int32_t(k), float(uv[q].first), float(uv[q].second)};
          a += L.du.cross(L.dv).norm();
        }
        area[k] = a / double(per) * (s.triangular(0) ? 0.5 : 1.0);
      }
    });
    lo_ = samples_[0].x;
    Vector3d hi = lo_;
    double total = 0;
    for (const Sample& q : samples_) {
      lo_ = lo_.cwiseMin(q.x);
      hi = hi.cwiseMax(q.x);
    }
    for (double a : area) total += a;
    // About two samples per occupied cell.
    h_ = std::sqrt(std::max(total, 1e-300) / double(samples_.size()) * 2.0);
    const double ext = (hi - lo_).maxCoeff();
    if (!(h_ > 0) || ext / h_ > 1e6) h_ = std::max(ext, 1e-300) / 1e6;
    keyed_.resize(samples_.size());
    for (size_t i = 0; i < samples_.size(); ++i) keyed_[i] = {key(cell(samples_[i].x)), std::int32_t(i)};
    std::sort(keyed_.begin(), keyed_.end());
    for (int a = 0; a < 3; ++a) dims_[a] = int(std::floor((hi[a] - lo_[a]) / h_)) + 1;
  }

  const Sample& sample(std::int32_t i) const { return samples_[i]; }

  /// The k nearest samples of p, nearest first.
  void nearest(const Vector3d& p, size_t k, std::vector<std::pair<double, std::int32_t>>& out) const {
    out.clear();
    const Eigen::Vector3i c = cell(p);
    const int rmax = std::max({dims_[0], dims_[1], dims_[2]}) + 1 +
                     int(std::ceil(((p - lo_).cwiseAbs().maxCoeff()) / h_));
    for (int r = 0; r <= rmax; ++r) {
      for (int dx = -r; dx <= r; ++dx)
        for (int dy = -r; dy <= r; ++dy)
          for (int dz = -r; dz <= r; ++dz) {
            if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != r) continue;
            const Eigen::Vector3i q = c + Eigen::Vector3i(dx, dy, dz);
            if ((q.array() < -1).any() || q[0] > dims_[0] || q[1] > dims_[1] || q[2] > dims_[2]) continue;
            const std::uint64_t kq = key(q);
            auto it = std::lower_bound(keyed_.begin(), keyed_.end(), std::make_pair(kq, std::int32_t(-1)));
            for (; it != keyed_.end() && it->first == kq; ++it)
              out.emplace_back((samples_[it->second].x - p).squaredNorm(), it->second);
          }
      if (out.size() >= k) {
        std::partial_sort(out.begin(), out.begin() + k, out.end());
        out.resize(k);
        // Cells of the next ring are at least r * h away.
        if (out.back().first <= double(r) * h_ * double(r) * h_) return;
      }
    }
    std::sort(out.begin(), out.end());
    if (out.size() > k) out.resize(k);
  }

 private:
  Eigen::Vector3i cell(const Vector3d& x) const {
    const Vector3d t = (x - lo_) / h_;
    return {int(std::floor(t[0])), int(std::floor(t[1])), int(std::floor(t[2]))};
  }
  static std::uint64_t key(const Eigen::Vector3i& c) {
    // Offsets keep the cells next to the box (down to -1) non-negative; 21 bits each.
    return (std::uint64_t(c[0] + 2) << 42) | (std::uint64_t(c[1] + 2) << 21) | std::uint64_t(c[2] + 2);
  }
  std::vector<Sample> samples_;
  std::vector<std::pair<std::uint64_t, std::int32_t>> keyed_;
  Vector3d lo_;
  double h_ = 1;
  int dims_[3] = {1, 1, 1};
};

}  // namespace

FootParam project_in_patch(const LimitSurface& surface, int patch, double u, double v, const Vector3d& p,
                           double tolerance) {
  const bool tri = surface.triangular(patch);
  project_domain(tri, u, v);
  LimitPoint L = surface.evaluate(patch, u, v);
  Vector3d r = L.p - p;
  double f = 0.5 * r.squaredNorm();
  // Newton reaches rounding (~1e-15 of the size) in a few steps where a foot point
  // exists; stop three orders below the tolerance.
  const double target = 1e-3 * tolerance;
  for (int it = 0; it < 50; ++it) {
    if (tangential(r, L.du, L.dv) <= target) break;
    const Eigen::Vector2d g(r.dot(L.du), r.dot(L.dv));
    Eigen::Matrix2d H;
    H << L.du.dot(L.du) + r.dot(L.duu), L.du.dot(L.dv) + r.dot(L.duv), L.du.dot(L.dv) + r.dot(L.duv),
        L.dv.dot(L.dv) + r.dot(L.dvv);
    // Far from the surface, or where it curves away, the Hessian may be indefinite:
    // then Gauss-Newton (J^T J), which always descends.
    if (!(H(0, 0) > 0 && H.determinant() > 0)) {
      H << L.du.dot(L.du), L.du.dot(L.dv), L.du.dot(L.dv), L.dv.dot(L.dv);
      H.diagonal() *= 1 + 1e-12;
    }
    const Eigen::Vector2d step = -H.ldlt().solve(g);
    if (!step.allFinite()) break;
    double alpha = 1;
    bool moved = false;
    for (int ls = 0; ls < 30; ++ls, alpha *= 0.5) {
      double un = u + alpha * step[0], vn = v + alpha * step[1];
      project_domain(tri, un, vn);
      if (un == u && vn == v) break;
      const LimitPoint Ln = surface.evaluate(patch, un, vn);
      const Vector3d rn = Ln.p - p;
      const double fn = 0.5 * rn.squaredNorm();
      // Near the solution f changes by rounding only (the tangential part is ~1e-9 of
      // d there, squared below f's last digit), so a step that shrinks the tangential
      // residual is taken too; the loop ends on the tangential test above.
      if (fn <= f || tangential(rn, Ln.du, Ln.dv) < tangential(r, L.du, L.dv)) {
        u = un;
        v = vn;
        L = Ln;
        r = rn;
        f = fn;
        moved = true;
        break;
      }
    }
    if (!moved) break;
  }
  FootParam out;
  out.patch = patch;
  out.u = u;
  out.v = v;
  out.residual = tangential(r, L.du, L.dv);
  out.distance = r.norm();
  return out;
}

std::vector<FootParam> find_foot_points(const LimitSurface& surface, const RowMatrixX3d& P,
                                        const std::vector<FootParam>& previous, double tolerance, int threads) {
  const SampleGrid grid(surface, threads);
  std::vector<FootParam> out(P.rows());
  const bool warm = previous.size() == size_t(P.rows());
  // A point costs tens of surface evaluations: blocks of 64 points as parallel items.
  const Index n = P.rows(), block = 64, blocks = (n + block - 1) / block;
  parallel_items(blocks, n * 64, threads, [&](Index blk) {
    const Index b = blk * block, e = std::min(n, b + block);
    std::vector<std::pair<double, std::int32_t>> near;
    std::vector<std::int32_t> tried;
    for (Index i = b; i < e; ++i) {
      const Vector3d p = P.row(i);
      FootParam best;
      best.residual = std::numeric_limits<double>::infinity();
      auto consider = [&](const FootParam& c) {
        if (c.residual <= tolerance ? (best.residual > tolerance || c.distance < best.distance)
                                    : c.residual < best.residual && best.residual > tolerance)
          best = c;
      };
      tried.clear();
      if (warm && previous[i].patch >= 0) {
        consider(project_in_patch(surface, previous[i].patch, previous[i].u, previous[i].v, p, tolerance));
        tried.push_back(previous[i].patch);
      }
      // First the patches of the 16 nearest samples, then of the 96 nearest (points
      // near a vertex of high valence, or far from the surface).
      for (size_t k : {size_t(16), size_t(96)}) {
        if (best.residual <= tolerance) break;
        grid.nearest(p, k, near);
        for (const auto& [dist2, s] : near) {
          const Sample& q = grid.sample(s);
          if (std::find(tried.begin(), tried.end(), q.patch) != tried.end()) continue;
          tried.push_back(q.patch);
          consider(project_in_patch(surface, q.patch, q.u, q.v, p, tolerance));
          if (best.residual <= tolerance) break;
        }
      }
      // Last resort for the rare point that is still without one (its foot point close
      // to a patch corner, reached from no sample's start): the patches of the 400
      // nearest samples, each from the corners' and the centre's neighbourhoods too.
      if (best.residual > tolerance) {
        grid.nearest(p, 400, near);
        tried.clear();
        const bool tri = surface.triangular(0);
        static const double starts_tri[][2] = {{0.05, 0.05}, {0.9, 0.05}, {0.05, 0.9}, {0.33, 0.33}};
        static const double starts_quad[][2] = {{0.05, 0.05}, {0.95, 0.05}, {0.05, 0.95}, {0.95, 0.95}, {0.5, 0.5}};
        for (const auto& [dist2, s] : near) {
          const std::int32_t patch = grid.sample(s).patch;
          if (std::find(tried.begin(), tried.end(), patch) != tried.end()) continue;
          tried.push_back(patch);
          const int n_starts = tri ? 4 : 5;
          for (int k = 0; k < n_starts && best.residual > tolerance; ++k) {
            const double* st = tri ? starts_tri[k] : starts_quad[k];
            consider(project_in_patch(surface, patch, st[0], st[1], p, tolerance));
          }
          if (best.residual <= tolerance) break;
        }
      }
      out[i] = best;
    }
  });
  return out;
}

}  // namespace vpffd::subdiv
