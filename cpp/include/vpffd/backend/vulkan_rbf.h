#pragma once
/// @file vulkan_rbf.h
/// The RBF regions frame (paper 002 §6) on a Vulkan device: the GPU counterpart of
/// RbfRegions::deform (multires/rbf_regions.h), part of target vpffd::vulkan. It takes
/// the precomputed setting as plain arrays (labels, the per-free-vertex basis, the
/// decomposition's rest data), so the Vulkan target does not depend on the RBF solve.
///
/// Per fine vertex, one compute invocation with no neighbours: fixed vertices keep
/// their rest fine vertex, normal and base vertex; a handle vertex of region k moves
/// by T_k (its normal by cof(A_k)); a free vertex gets S' = S + sum_k D_k alpha_k(S),
/// S'_u, S'_v and its base vertex from its 16 K basis reals, then p' = S' + d N_S' and
/// the approximate normal of eqs. 6-7 (reconstruct_vertex). Uploaded once: labels
/// (8 bytes), 12 rest reals, 10 floats per vertex and 16 K reals per free vertex; a
/// frame uploads the K maps (33 reals each), runs one dispatch in one submission and
/// reads back vertices, normals and base vertices (36 bytes per vertex).
///
/// Precision: rest points, basis and maps are reals (float64 or float-float,
/// Precision), in device units (relative to origin(), in units of scale()); the affine
/// sums are formed in reals and rounded once to float32; d, the coefficients, the rest
/// normals and the rebuild are float32. The error against the CPU frame is bounded per
/// vertex in tests/python/test_rbf_regions_vulkan.py (rbf_bounds).
///
/// Threads: deform() and last_timings() may be called from several threads; frames run
/// one at a time. The device is shared with every other Vulkan frame on it.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "vpffd/backend/vulkan.h"

namespace vpffd::vulkan {

/// The regions setting as plain arrays (not copied: read by the constructor only).
struct RbfRegionsView {
  Index n_vertices = 0;                  ///< V, fine vertices
  Index n_regions = 0;                   ///< K >= 1 handle regions
  const std::int32_t* labels = nullptr;  ///< V: -1 fixed, 0 free, k in 1..K handle region k
  const double* basis = nullptr;         ///< F x 16K row-major, F the free vertices in ascending order
                                         ///< (RbfRegions' coefficients: alpha_k at S, along S_u, S_v, at the base)
  const double* foot = nullptr;          ///< V x 3 rest foot points S(t_i), world units
  const double* su = nullptr;            ///< V x 3 rest tangents S_u, world units per parameter
  const double* sv = nullptr;            ///< V x 3 rest tangents S_v
  const double* fine = nullptr;          ///< V x 3 rest fine vertices, world units
  const double* normals = nullptr;       ///< V x 3 unit rest normals
  const double* base = nullptr;          ///< V x 3 rest base vertices, world units
  const double* d = nullptr;             ///< V signed displacements, world units
  const double* coef = nullptr;          ///< V x 6 row-major a_u, b_u, g_u, a_v, b_v, g_v (eqs. 6-7)
};

/// Deformed fine vertices, normals and base vertices of one device frame.
struct RbfDeviceFrame {
  RowMatrixX3d vertices;  ///< #V x 3 p'
  RowMatrixX3d normals;   ///< #V x 3 unit normals
  RowMatrixX3d base;      ///< #V x 3 base vertices
};

/// The RBF regions frame on a device.
class VulkanRbfFrame {
 public:
  /// Checks and uploads the setting.
  /// @param[in] s          the setting (see RbfRegionsView)
  /// @param[in] device     as VulkanDeformer: "" (first suitable), an index, or part of a name
  /// @param[in] precision  how the affine sums are formed (Float64 needs shaderFloat64)
  /// @throws InvalidInputError for inconsistent arrays (a label out of range, no free
  ///         vertex, a non-finite datum, sizes beyond 32-bit device indices),
  ///         BackendUnavailableError when no Vulkan device is found or Float64 is asked
  ///         of a device without it, DeviceError when a Vulkan call fails
  explicit VulkanRbfFrame(const RbfRegionsView& s, const std::string& device = "",
                          Precision precision = Precision::Auto);
  ~VulkanRbfFrame();
  VulkanRbfFrame(const VulkanRbfFrame&) = delete;
  VulkanRbfFrame& operator=(const VulkanRbfFrame&) = delete;

  /// One frame for the K affine maps T (4 x 4, last row (0, 0, 0, 1), world units).
  /// @throws InvalidInputError as RbfRegions::deform (count, NaN, non-affine, singular),
  ///         or a map moving the setting beyond float32's range on the device;
  ///         DeviceError on a device failure
  RbfDeviceFrame deform(const std::vector<Eigen::Matrix4d>& T);
  /// deform() into the caller's #V x 3 row-major arrays (any may be null; the same bits).
  void deform(const std::vector<Eigen::Matrix4d>& T, double* vertices, double* normals, double* base);

  Index n_vertices() const;
  Index n_regions() const;
  Index n_free() const;
  const DeviceInfo& device() const;
  /// Float64 or FloatFloat (never Auto).
  Precision precision() const;
  /// The last frame: gpu_total and host_total, milliseconds (as VulkanSubdivFrame).
  FrameTimings last_timings() const;
  /// Reference point (the rest fine and base vertices' box centre) and unit (the power
  /// of two nearest to its half diagonal) of the device positions.
  const Vector3d& origin() const;
  double scale() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vpffd::vulkan
