#pragma once
// The limit surface of a control mesh through OpenSubdiv's Bfr (one Bfr::Surface per
// control face), in our own patch numbering: a patch is a control face, or one
// normalised sub-face (a Ptex face) of a Catmull-Clark triangle. Only this file and
// limit_surface.cpp see OpenSubdiv types.

#include <cstdint>
#include <memory>
#include <vector>

#include "vpffd/core/types.h"
#include "vpffd/subdiv/subdivision_multires.h"

namespace vpffd::subdiv {

/// Position and first and second derivatives of S at a patch parameter.
struct LimitPoint {
  Vector3d p, du, dv, duu, duv, dvv;
};

class LimitSurface {
 public:
  /// Builds the topology and one surface per control face.
  /// @throws InvalidInputError when OpenSubdiv refuses the topology
  LimitSurface(SubdivScheme scheme, Index n_control, const std::vector<std::int32_t>& face_sizes,
               const std::vector<std::int32_t>& face_vertices, int approx_level);
  ~LimitSurface();
  LimitSurface(const LimitSurface&) = delete;
  LimitSurface& operator=(const LimitSurface&) = delete;

  int n_patches() const { return int(patch_face_.size()); }
  /// True when the patch's domain is the unit triangle (Loop), else the unit square.
  bool triangular(int patch) const { return triangular_; }
  int face_of(int patch) const { return patch_face_[patch]; }

  /// Sets the control points (M x 3) that evaluate() uses; not thread-safe, call
  /// it before evaluating.
  void set_points(const RowMatrixX3d& C);
  /// S and its derivatives in the patch's own (u, v); thread-safe after set_points.
  LimitPoint evaluate(int patch, double u, double v) const;
  /// Weights of S, S_u, S_v over control points at (patch, u, v), appended to the
  /// vectors (one entry per control point that influences the patch).
  void stencil(int patch, double u, double v, std::vector<std::int32_t>& idx, std::vector<double>& w,
               std::vector<double>& wu, std::vector<double>& wv) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<std::int32_t> patch_face_, patch_sub_;
  bool triangular_ = false;
};

}  // namespace vpffd::subdiv
