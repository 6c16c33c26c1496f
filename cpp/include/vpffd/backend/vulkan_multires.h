#pragma once
/// @file vulkan_multires.h
/// The multiresolution frame (paper 002, eq. 1 and eqs. 6-7) on a Vulkan device: the
/// GPU counterpart of MultiresFFD (multires/ffd_map.h), part of target vpffd::vulkan.
///
/// Per fine vertex, one compute invocation with no neighbours: S' = D(S(t_i)),
/// S'_u = J_D S_u, S'_v = J_D S_v (B-spline values and first derivatives at the foot
/// point), N_S' = unit(S'_u x S'_v), p' = S' + d N_S', and the approximate normal of
/// eqs. 6-7. The foot points are fixed rest-space points, so their embedding (span and
/// local parameter per axis), S_u, S_v, d and the six coefficients are uploaded once
/// (frame_bytes_per_vertex); a frame uploads the control points (12 bytes each), runs
/// one dispatch in one submission and reads back positions and normals (24 bytes per
/// vertex). A volume-corrected frame is one submission too: deform(correction, P, opt)
/// appends the reconstruction to a VulkanDeformer's frame (of the base or the fine
/// mesh) on the same device, and the dispatch reads the corrected control points
/// (P + offsets) from that Deformer's device buffers, with no host round trip.
///
/// Precision: control points, positions, tangents, d and the coefficients are float32
/// on the device (positions relative to origin(), in units of scale(), as the
/// VulkanDeformer's); the basis values and derivatives are evaluated in float64 or
/// float-float (Precision) and rounded once to float32. The error against the CPU's
/// MultiresFFD is bounded per vertex in tests/python/gpu_bounds.py (multires_bounds):
/// for a cubic lattice a worst case of a few 1e-6 of the box diagonal for positions
/// (about 26 float32 roundings of terms up to half the diagonal, plus |d| times the
/// normal's direction error) and below 0.01 degree for the normals of a moderate edit;
/// lavapipe's errors are about 5e-8 of the diagonal and 2e-5 degree.
///
/// Periodic lattices: as MultiresFFD, the control points given are the distinct ones
/// (expanded to the extended lattice, each rounded once to float32), the foot points are
/// wrapped into the box on the host, and the seams' translations and mirrors are per
/// vertex data (a shift seam adds 12 bytes per vertex: its translation, added to D in
/// float32).
///
/// Threads: deform() and last_timings() may be called from several threads; frames run
/// one at a time. The device is shared with every VulkanDeformer on it.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "vpffd/backend/vulkan.h"
#include "vpffd/multires/ffd_map.h"

namespace vpffd::vulkan {

/// A multiresolution frame that follows a VulkanDeformer's frame in one submission.
struct MultiresDeviceFrame {
  DeformResult correction;     ///< the Deformer's frame; its control_points drove the reconstruction
                               ///< (its `vertices` are empty: see base_vertices)
  MultiresFrame frame;         ///< fine vertices and approximate unit normals, input order
  RowMatrixX3d base_vertices;  ///< #V x 3 deformed base mesh (see VulkanMultires::deform)
};

/// FFD of a decomposition's base with the fine mesh rebuilt per vertex on a device.
class VulkanMultires {
 public:
  /// Embeds the foot points (on the host, once, as MultiresFFD) and uploads the frame data.
  /// @param[in] m       the decomposition (shared, not copied)
  /// @param[in] L       lattice (its box should contain the base mesh; foot points
  ///                    outside follow the boundary polynomial pieces, as on the CPU)
  /// @param[in] device  as VulkanDeformer: "" (first suitable), an index, or part of a name
  /// @param[in] precision  how the basis is evaluated (Float64 needs shaderFloat64)
  /// @throws InvalidInputError for a bad lattice (as MultiresFFD) or a mesh too large
  ///         for 32-bit device indices, BackendUnavailableError when no Vulkan device
  ///         is found, DeviceError when a Vulkan call fails
  VulkanMultires(std::shared_ptr<const Multires> m, Lattice L, const std::string& device = "",
                 Precision precision = Precision::Auto);
  ~VulkanMultires();
  VulkanMultires(const VulkanMultires&) = delete;
  VulkanMultires& operator=(const VulkanMultires&) = delete;

  /// One frame with control points P (N x 3, world units; a periodic lattice's distinct
  /// ones, cpu().n_control_points()): the fine vertices and
  /// their approximate unit normals (zero rows where the deformed tangents are
  /// parallel), input vertex order.
  /// @throws InvalidInputError for a wrong row count, NaN or Inf, or a control point
  ///         more than 2^100 box half-diagonals from the box centre (float32 range on
  ///         the device); DeviceError on a device failure
  MultiresFrame deform(const Eigen::Ref<const RowMatrixX3d>& P);
  /// deform() into the caller's #V x 3 row-major arrays (both not null; the same bits).
  void deform(const Eigen::Ref<const RowMatrixX3d>& P, double* vertices, double* normals);

  /// One frame in one submission: `correction`'s frame (P and opt exactly as
  /// correction.deform(P, opt)), then, on the device, its corrected control points
  /// P + offsets (summed in the device's reals, rounded once to float32) and the
  /// reconstruction from them.
  /// - `correction` is the Deformer of the base mesh (base == nullptr): its vertices
  ///   are the deformed base (`base_vertices`), read back with the frame;
  /// - or of the fine mesh: then `base`, the Deformer of the base mesh, runs the plain
  ///   FFD of the corrected control points in the same submission and gives
  ///   `base_vertices` (its device vertices become those; after a correction that fails
  ///   on the device they are the FFD of the failed frame's control points).
  /// Both must be on this device, with this lattice and precision. Frames that share
  /// a Deformer run one at a time: this lock is taken first, then correction's,
  /// then base's.
  /// @throws InvalidInputError for a Deformer of another device, lattice or precision
  ///         (or base == &correction), and whatever correction.deform throws (then no
  ///         reconstruction is returned)
  /// `vertices` / `normals` (#V x 3 row-major, or null): the caller's arrays, filled
  /// instead of the frame's (then empty).
  MultiresDeviceFrame deform(VulkanDeformer& correction, const Eigen::Ref<const RowMatrixX3d>& P,
                             const CorrectionOptions& opt, VulkanDeformer* base = nullptr,
                             double* vertices = nullptr, double* normals = nullptr);

  /// The CPU counterpart on the same decomposition and lattice (its embedding is the
  /// device's).
  const MultiresFFD& cpu() const;
  const DeviceInfo& device() const;
  /// Float64 or FloatFloat (never Auto).
  Precision precision() const;
  /// The last frame: gpu_total (its dispatch and copies, when the queue has
  /// timestamps; after a Deformer's frame: from the end of that frame, which has its
  /// own timings, to the end of the submission) and host_total (deform(), end to end,
  /// the Deformer's frame included), milliseconds.
  FrameTimings last_timings() const;
  /// Reference point (the lattice box centre) and unit (the power of two nearest to its
  /// half diagonal) of the device positions, as VulkanDeformer's.
  const Vector3d& origin() const;
  double scale() const;

  /// Device bytes per vertex: 3 span indices (12) and 16 floats of frame data (64),
  /// uploaded once (a periodic lattice with a shift seam: 12 more); the outputs add 24.
  static constexpr int frame_bytes_per_vertex = 3 * 4 + 16 * 4;

  /// For a renderer on the same VkDevice: raw VkBuffer handles of the positions
  /// (#V x 3 float32, (p' - origin()) / scale()) and normals (#V x 3 float32) of the
  /// last frame, in the device's vertex order: device vertex i is input vertex
  /// vertex_order()[i] (foot points sorted by lattice cell, so neighbouring
  /// invocations read the same control points).
  std::uint64_t vertex_buffer_handle() const;
  std::uint64_t normal_buffer_handle() const;
  const std::vector<std::int32_t>& vertex_order() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vpffd::vulkan
