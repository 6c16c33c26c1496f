#pragma once
// Exact foot points on a limit surface: per point p, a parameter t = (patch, u, v)
// where p - S(t) is parallel to N_S(t), found by projected Newton steps on
// f(u, v) = |S(u, v) - p|^2 / 2 inside one patch's domain, started in the patches of
// the nearest samples of a dense tessellation of the limit surface.

#include <cstdint>
#include <vector>

#include "limit_surface.h"

namespace vpffd::subdiv {

struct FootParam {
  std::int32_t patch = -1;
  double u = 0, v = 0;
  double residual = 0;  ///< tangential residual, world units
  double distance = 0;  ///< |p - S(t)|
};

/// Foot points of the rows of P on `surface` (its points set). `previous` (empty, or
/// one per row) is tried first: the warm start of a fitting round. A point whose
/// best candidate has a residual above `tolerance` (world units) keeps that best
/// candidate; the caller reports it.
std::vector<FootParam> find_foot_points(const LimitSurface& surface, const RowMatrixX3d& P,
                                        const std::vector<FootParam>& previous, double tolerance, int threads);

/// Newton on one patch from (u, v); returns the point reached. Exposed for tests.
FootParam project_in_patch(const LimitSurface& surface, int patch, double u, double v, const Vector3d& p,
                           double tolerance);

}  // namespace vpffd::subdiv
