#pragma once
/// @file vulkan_subdiv.h
/// The frame of a displaced subdivision surface (paper 002 §5.2) on a Vulkan device:
/// the GPU counterpart of deform_subdivision (subdiv/subdivision_frame.h), part of
/// target vpffd::vulkan. It takes the decomposition as plain arrays (the limit
/// stencils, d and the coefficients), so the Vulkan target does not depend on
/// OpenSubdiv.
///
/// Per fine vertex, one compute invocation with no neighbours: S' = sum_j w_j C_j,
/// S'_u, S'_v likewise from its stencil row (CSR), N_S' = unit(S'_u x S'_v),
/// p' = S' + d N_S' and the approximate normal of eqs. 6-7 (reconstruct_vertex).
/// The stencils (4 bytes of index and 3 reals, 28 bytes, per entry), d and the six
/// coefficients (28 bytes per vertex) are uploaded once; a frame uploads the control
/// points (12 bytes each), runs one dispatch in one submission and reads back
/// positions, normals and limit points (36 bytes per vertex).
///
/// Precision: control points, positions, normals, d and the coefficients are float32
/// on the device (positions relative to origin(), in units of scale()); the stencil
/// weights are reals and the stencil sums are formed in float64 or float-float
/// (Precision) from the float32 control points, then rounded once to float32. The
/// error against the CPU frame is bounded per vertex in
/// tests/python/test_subdivision_vulkan.py (subdiv_bounds).
///
/// Threads: deform() and last_timings() may be called from several threads; frames run
/// one at a time. The device is shared with every other Vulkan frame on it.

#include <cstdint>
#include <memory>
#include <string>

#include "vpffd/backend/vulkan.h"

namespace vpffd::vulkan {

/// The decomposition's frame data as plain arrays (not copied: read by the constructor only).
struct SubdivStencilsView {
  Index n_vertices = 0;                    ///< V, fine vertices
  Index n_control = 0;                     ///< M, control points
  const std::int64_t* indptr = nullptr;    ///< V + 1 CSR row starts (indptr[0] == 0, non-decreasing)
  const std::int32_t* indices = nullptr;   ///< indptr[V] control points, each in [0, M)
  const double* w = nullptr;               ///< indptr[V] position weights
  const double* wu = nullptr;              ///< indptr[V] d/du weights
  const double* wv = nullptr;              ///< indptr[V] d/dv weights
  const double* d = nullptr;               ///< V signed displacements, world units
  const double* coef = nullptr;            ///< V x 6 row-major a_u, b_u, g_u, a_v, b_v, g_v (eqs. 6-7)
};

/// Deformed fine vertices, approximate normals and limit points of one device frame.
struct SubdivDeviceFrame {
  RowMatrixX3d vertices;  ///< #V x 3 p'
  RowMatrixX3d normals;   ///< #V x 3 unit approximate normals (zero where S'_u || S'_v)
  RowMatrixX3d base;      ///< #V x 3 S'(t_i)
};

/// The displaced-subdivision-surface frame on a device.
class VulkanSubdivFrame {
 public:
  /// Checks and uploads the frame data.
  /// @param[in] s          the stencils, d and coefficients (see SubdivStencilsView)
  /// @param[in] rest       M x 3 rest control points (world units): their bounding box
  ///                       gives the device units (origin(), scale())
  /// @param[in] device     as VulkanDeformer: "" (first suitable), an index, or part of a name
  /// @param[in] precision  how the stencil sums are formed (Float64 needs shaderFloat64)
  /// @throws InvalidInputError for inconsistent arrays (an index out of range, a
  ///         decreasing indptr, a non-finite weight or datum, sizes beyond 32-bit device
  ///         indices), BackendUnavailableError when no Vulkan device is found or
  ///         Float64 is asked of a device without it, DeviceError when a Vulkan call fails
  VulkanSubdivFrame(const SubdivStencilsView& s, const Eigen::Ref<const RowMatrixX3d>& rest,
                    const std::string& device = "", Precision precision = Precision::Auto);
  ~VulkanSubdivFrame();
  VulkanSubdivFrame(const VulkanSubdivFrame&) = delete;
  VulkanSubdivFrame& operator=(const VulkanSubdivFrame&) = delete;

  /// One frame with control points C (M x 3, world units), input vertex order.
  /// @throws InvalidInputError for a wrong row count or a non-finite entry (the CPU
  ///         frame's messages), or a control point more than 2^100 scale() units from
  ///         origin() (float32 range on the device); DeviceError on a device failure
  SubdivDeviceFrame deform(const Eigen::Ref<const RowMatrixX3d>& C);
  /// deform() into the caller's #V x 3 row-major arrays (any may be null; the same bits).
  void deform(const Eigen::Ref<const RowMatrixX3d>& C, double* vertices, double* normals, double* base);

  Index n_vertices() const;
  Index n_control() const;
  const DeviceInfo& device() const;
  /// Float64 or FloatFloat (never Auto).
  Precision precision() const;
  /// The last frame: gpu_total (copies and dispatch, when the queue has timestamps)
  /// and host_total (deform(), end to end), milliseconds.
  FrameTimings last_timings() const;
  /// Reference point (the rest control points' box centre) and unit (the power of two
  /// nearest to its half diagonal) of the device positions.
  const Vector3d& origin() const;
  double scale() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vpffd::vulkan
