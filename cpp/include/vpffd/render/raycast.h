#pragma once
/// @file raycast.h
/// Ray casting against a triangle mesh with Embree 3 (target vpffd::embree):
/// picking (first hit of a ray) and a small ray-cast renderer with smooth shading,
/// per-vertex colours and a lattice overlay (lines and points).
///
/// This header has no Embree include (pimpl); the implementation is in cpp/src/embree.
/// Embree works in float32 on a normalised copy of the mesh (centred, scaled by a
/// power of two into [-1, 1]^3), so any mesh whose bounding box fits the double
/// range can be ray cast. Embree finds the face; the hit is then recomputed in
/// double (Moeller-Trumbore on the double triangle): point, distance and
/// barycentrics are double precision, the barycentrics in [0, 1].

#include <cstdint>
#include <memory>
#include <vector>

#include "vpffd/core/types.h"

namespace vpffd {

/// A pinhole camera. Image pixel (x, y), x to the right and y downwards from the
/// top-left corner, is the ray through the pixel's centre (x + 0.5, y + 0.5).
struct RenderCamera {
  Vector3d eye{0, -3, 0};     ///< position (world units)
  Vector3d target{0, 0, 0};   ///< point looked at
  Vector3d up{0, 0, 1};       ///< up direction (need not be orthogonal to the view)
  double fov_degrees = 40.0;  ///< vertical field of view
};

/// Unit direction of the ray through pixel (x, y) of a width x height image
/// (x, y may be fractional: the pixel centre is x + 0.5).
/// @throws InvalidInputError for a degenerate camera
Vector3d camera_ray(const RenderCamera& cam, int width, int height, double x, double y);

/// The first hit of one ray.
struct RayHit {
  bool hit = false;
  Index face = -1;        ///< hit triangle
  double u = 0, v = 0;    ///< barycentric weights of the face's corners 1 and 2 (corner 0: 1 - u - v), all in [0, 1]
  double distance = 0;    ///< along the (normalised) ray direction, world units
  Vector3d point = Vector3d::Zero();  ///< (1-u-v) p0 + u p1 + v p2, in double
};

/// What render() draws besides the mesh.
struct RenderOptions {
  int width = 800, height = 600;
  int samples = 1;  ///< supersampling per axis (1: none, 2: 4 rays per pixel, ...)
  bool adaptive = true;  ///< supersample only pixels next to an edge (silhouette, depth or colour step)
  Vector3d background{1.0, 1.0, 1.0};  ///< RGB in [0, 1]
  Vector3d base_color{0.72, 0.74, 0.78};  ///< surface colour without vertex colours
  RowMatrixX3d vertex_colors;  ///< #V x 3 RGB in [0, 1], or 0 rows
  RowMatrixX3d normals;        ///< #V x 3 shading normals, or 0 rows for area-weighted ones
  RowMatrixX3d points;         ///< lattice control points drawn as discs (n x 3), or 0 rows
  Eigen::Matrix<std::int32_t, Eigen::Dynamic, 2, Eigen::RowMajor> lines;  ///< index pairs into points
  Vector3d line_color{0.85, 0.25, 0.15};
  Vector3d point_color{0.1, 0.2, 0.8};
  double point_radius = 3.0;   ///< pixels
  double hidden_alpha = 0.25;  ///< opacity of overlay parts behind the surface (0: hide them), times line_alpha
  double line_alpha = 1.0;     ///< opacity of the visible lattice lines
  double line_width = 1.0;     ///< pixels (lines are anti-aliased)
};

/// A triangle mesh loaded into an Embree scene; build once, then pick and render
/// as often as needed (thread-safe for concurrent queries; set_vertices waits for
/// the queries running on other threads and holds new ones off until it is done).
class RayScene {
 public:
  /// @param[in] V  #V x 3 vertex positions
  /// @param[in] F  #F x 3 triangles
  /// @param[in] fast_build  a quicker, less optimised BVH (Embree's low build quality):
  ///                        for a scene rendered once, where the build costs more than the rays
  /// @param[in] refit  the mesh will move (set_vertices): its BVH is built once and then
  ///                   refitted to the new positions instead of rebuilt, several times faster
  ///                   than a build; rays cost a little more the further the mesh moves
  /// @throws InvalidInputError for a bad mesh, DeviceError when Embree fails
  RayScene(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
           bool fast_build = false, bool refit = false);
  ~RayScene();
  RayScene(const RayScene&) = delete;
  RayScene& operator=(const RayScene&) = delete;

  /// Moves the vertices to V (#V x 3, the same count; the faces stay): queries then give
  /// the hits of a scene built from V. The BVH is refitted when the scene was constructed
  /// with refit = true, else rebuilt.
  /// @throws InvalidInputError for a wrong row count or non-finite coordinates (the scene
  ///         is then unchanged), DeviceError when Embree fails
  void set_vertices(const Eigen::Ref<const RowMatrixX3d>& V);

  /// First hits of n rays.
  /// @param[in] origins     n x 3 ray origins
  /// @param[in] directions  n x 3 directions (normalised here; must be non-zero)
  /// @param[in] tmin        hits closer than this (along the unit direction) are ignored
  /// @throws InvalidInputError for a ray whose origin is so far from the mesh (about 1e23
  ///         mesh sizes, unless axis-aligned) that double precision cannot place it near the
  ///         mesh to float32 accuracy
  std::vector<RayHit> intersect(const Eigen::Ref<const RowMatrixX3d>& origins,
                                const Eigen::Ref<const RowMatrixX3d>& directions, double tmin = 0.0) const;

  /// Ray-cast image, height x width x 3 bytes (row-major, top row first).
  /// @param[out] depth  optional: height x width distances to the surface (inf for background)
  std::vector<std::uint8_t> render(const RenderCamera& cam, const RenderOptions& opt,
                                   std::vector<float>* depth = nullptr) const;

  Index n_vertices() const;
  Index n_faces() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vpffd
