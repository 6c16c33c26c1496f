#pragma once
/// @file vulkan.h
/// The GLSL/Vulkan compute backend (target vpffd::vulkan, macro VPFFD_HAS_VULKAN).
///
/// A VulkanDeformer runs a whole frame on one device: plain FFD, per axis step
/// (`rounds` times through the axes) the volume coefficients, the closed-form offsets
/// and the update of the vertices, and the volume measurements, in a single queue
/// submission. Mesh data are uploaded once, and the rest positions, from which the
/// device computes the per-vertex basis data (span, local parameter) and the sort of
/// the vertices by lattice cell, at construction and per set_rest_vertices; the frame's
/// command buffer is recorded once per options shape (axes, rounds, volume or not)
/// and reused; a frame uploads the control points and a few scalars (the point
/// constraints' block only when the constraint sources or the weights change) and
/// reads back the N x 3 offsets and a few scalars; the vertices stay on the device
/// until vertices() asks for them. Point constraints: any number the CPU backend
/// takes (up to the number of free control points); with a volume correction their
/// block C = R W^-1 R^T is factored on the host once per constraint set (O(nc^3))
/// and each device step costs O(nc^2); without one they do not depend on the mesh
/// and are solved on the host exactly as the CPU backend solves them. Parts (at most
/// 64): each part's vertices are sorted into their own tiles (the sort key is part,
/// then cell), each step sums one coefficient row and one volume per part, and the
/// device eliminates the constraints from the K volume rows (a K x K Schur complement,
/// factored LDL^T in the step's solve workgroup): the CPU's solve_axis_offsets_parts
/// in one submission, each part's share of what it misses per step as on the CPU. A
/// row the device finds zero or dependent is named by the CPU backend's own message.
///
/// Precision: positions, control points and basis values are float32 on the device
/// (positions relative to origin()); weights, coefficients, volumes and offsets are
/// summed in float64, or, with Precision::FloatFloat (automatic on devices without
/// shaderFloat64), in float-float pairs of about 48 significant bits made of float32
/// arithmetic alone (shaders/real.glsl); its range is float32's. How far a result
/// may be from the CPU backend's follows from that arithmetic, for any correctly
/// rounding driver (derivation and formulas: tests/python/gpu_bounds.py, used by the
/// tests in both languages): a vertex coordinate within u (basis + K + 3) max|P - o|
/// plus, per axis step, u ((basis + K + 3) max|offset| + max|x - o|), with u = 2^-24,
/// K the control points per vertex (64 for cubics) and `basis` the float32 basis
/// values' error (a few hundred u for cubics); for a cubic lattice about 3e-5 of the
/// box diagonal. A corrected volume is measured on the device after each step, so
/// only the last step's rounding stays: within u sum_v |dV/dx_v,a| (|x_v,a - o_a| + ...),
/// about u = 6e-8 relative for a convex mesh. These are worst cases; on lavapipe the
/// largest seen over degrees 1-5, axis subsets, weights, constraints and rounds are
/// 4.1e-7 of the diagonal and 7.0e-9 relative; the dragon's corrected volume is within
/// 3e-11 (float64) and 9e-12 (float-float) of the target.
///
/// Threads: every public member may be called from several threads on one deformer,
/// moves of the rest mesh (set_rest_vertices, set_rest_offsets) included. Frames run
/// one at a time, each against one rest state from its options' checks to its read
/// back (a move waits for the frame in flight), and each deform() returns its own
/// frame's vertices and leaves its own timings. The reference cpu() returns is the
/// CPU twin of the rest mesh at that call; its own members are safe beside moves
/// (Deformer's rule), but it follows a later move only when cpu() is called again.
///
/// Errors: a frame that fails (InvalidInputError, SolverError) leaves the device
/// vertices (vertices(), vertex_buffer_handle()) those of the last frame that
/// succeeded, or the rest mesh. Most failures are found on the host before the
/// frame runs; a volume correction that fails on the device (zero coefficients,
/// dependent rows) restores the vertices it overwrote, which costs a copy of the
/// vertices (12 bytes per vertex of device memory, and of traffic per frame).
///
/// Vulkan is loaded at run time (volk): nothing here needs a Vulkan driver until a
/// device is asked for, and then a missing one raises BackendUnavailableError.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "vpffd/correction/options.h"
#include "vpffd/frame/deformer.h"
#include "vpffd/lattice/embed.h"
#include "vpffd/lattice/lattice.h"

namespace vpffd::vulkan {

/// One physical device as the Vulkan loader reports it.
struct DeviceInfo {
  int index = -1;                 ///< position in vkEnumeratePhysicalDevices
  std::string name;               ///< e.g. "NVIDIA H100 80GB HBM3", "llvmpipe (LLVM 15.0.6, 256 bits)"
  std::string type;               ///< "discrete", "integrated", "virtual", "cpu" or "other"
  std::uint64_t memory_bytes = 0; ///< largest device-local heap, bytes
  std::string api_version;        ///< "1.3.239"
  std::string driver;             ///< driver name and info when the driver reports them
  bool float64 = false;           ///< shaderFloat64 (without it the sums are float-float)
  bool suitable = false;          ///< usable by vpffd
  std::string reason;             ///< why not, when !suitable
  bool software() const { return type == "cpu"; }
};

/// Devices of the Vulkan loader; empty when there is no loader or no driver
/// (then `why`, when given, says which).
std::vector<DeviceInfo> devices(std::string* why = nullptr);

/// How the device sums (see the file comment).
enum class Precision {
  Auto,        ///< Float64 when the device has shaderFloat64, else FloatFloat
  Float64,     ///< needs shaderFloat64
  FloatFloat,  ///< float32 pairs: any device; an option where float64 runs at a small fraction of
               ///< float32 (unmeasured on GPUs; on lavapipe 1.2x slower than Float64)
};
/// "auto", "float64", "float-float".
const char* precision_name(Precision p);
/// The inverse of precision_name. @throws InvalidInputError naming the accepted values.
Precision parse_precision(const std::string& name);

/// GPU and host times of the last frame, milliseconds.
struct FrameTimings {
  double gpu_total = 0;           ///< timestamp queries: first to last command of the frame
  double gpu_ffd = 0;             ///< plain FFD (and the volume before correction)
  std::vector<double> gpu_steps;  ///< each axis step: coefficients, solve, vertex update (constraints
                                  ///< alone: each axis's vertex update)
  double gpu_final = 0;           ///< final volume measurement and copies
  double gpu_move = 0;            ///< a move's device embedding that ran first in this frame's submission
                                  ///< (embedding, cell sort, tiles; set_rest_vertices), not in gpu_total;
                                  ///< 0 when no move waited for the frame
  double gpu_readback = 0;        ///< the read back's device work (the vertices put in the caller's
                                  ///< order, and their copy to host memory), after gpu_total; 0
                                  ///< without vertices read back
  double host_total = 0;          ///< deform() call, end to end (upload, submit, wait, read back)
  /// The host's stages of host_total: the options' checks, the plan and the staging of
  /// the control points and frame data in mapped memory (and recording, when the
  /// frame's shape is new); the submission until the queue is idle again (the device's
  /// work, gpu_total, and the driver's around it); the read back of the vertices (and
  /// normals) from the mapped buffer into the caller's order in float64.
  double host_prepare = 0, host_submit_wait = 0, host_unpack = 0;
  bool has_timestamps = false;    ///< false when the queue has no timestamp support
};

/// Volume-preserving FFD of one mesh on one Vulkan device. Same semantics, options,
/// results and error messages as vpffd::Deformer (the CPU reference); only the
/// arithmetic differs (see the file comment).
class VulkanDeformer {
 public:
  /// Uploads the mesh and embeds its vertices on the device (as set_rest_vertices).
  /// @param[in] V       #V x 3 rest vertices
  /// @param[in] F       #F x 3 triangles
  /// @param[in] device  "" (the first suitable device: hardware before software),
  ///                    a device index ("0"), or a case-insensitive part of its name
  /// @param[in] precision  how the device sums; Float64 on a device without
  ///                    shaderFloat64 raises BackendUnavailableError
  /// @throws InvalidInputError for bad input (as the CPU Deformer),
  ///         BackendUnavailableError when no Vulkan or no suitable device is found,
  ///         DeviceError when a Vulkan call fails (the message names the call)
  /// @param[in] parts  null, or the mesh's parts (mesh/parts.h), as for Deformer: each
  ///                    part then keeps its own volume (one volume row per part in every
  ///                    device axis step), at most MAX_DEVICE_PARTS (64) of them
  VulkanDeformer(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F, Lattice L,
                 OutsidePolicy policy = OutsidePolicy::Error, const std::string& device = "",
                 Precision precision = Precision::Auto, const MeshParts* parts = nullptr);
  ~VulkanDeformer();
  VulkanDeformer(const VulkanDeformer&) = delete;
  VulkanDeformer& operator=(const VulkanDeformer&) = delete;

  /// One frame with control points P (N x 3; the distinct ones of a periodic lattice,
  /// as Deformer::deform: the device expands them and solves for them, and on periodic
  /// axes wraps the rest vertices into the box). `opt.method` and `opt.threads` are
  /// ignored (the device always uses the traversal; method='csr' is still refused on
  /// an open mesh, as on the CPU, so both backends accept the same options). With read_vertices false the
  /// result's `vertices` is empty: call vertices() when they are needed. Errors are
  /// the CPU backend's (for dependent constraint rows it is asked for its message).
  /// With `normals` (not null) *normals receives the #V x 3 unit normals of the
  /// deformed surface at its vertices (input order), computed in the same submission: cof(J) n0
  /// normalised, J the FFD's Jacobian of the corrected control points at the rest
  /// vertex and n0 the rest mesh's vertex_normals, as deformed_normals_exact on the
  /// CPU; float32 arithmetic (their angle to the CPU's: tests/python/gpu_bounds.py,
  /// normal_angle_bound). Zero rows where cof(J) n0 vanishes.
  /// @throws as Deformer::deform; a device failure throws DeviceError
  DeformResult deform(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt,
                      bool read_vertices = true, RowMatrixX3d* normals = nullptr);
  /// deform() into the caller's #V x 3 row-major arrays (the same bits): the vertices
  /// into `vertices` (null: not read back, as read_vertices false) and, when `normals`
  /// is not null, the normals into it. The result's `vertices` is empty.
  DeformResult deform(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt, double* vertices,
                      double* normals);
  /// deform() whose vertices are not copied: *vertices points at the #V x 3 row-major
  /// float64 vertices (input order) in the host memory the device read them back into.
  /// The lifetime rule: they stay valid and unchanged while *vertices (or a copy of it)
  /// is held, also after the deformer is gone; the deformer writes that memory again
  /// only once nobody holds it. It keeps up to three such buffers; while all are held
  /// a frame copies into new memory instead. In float-float precision (whose shaders
  /// read back float32) the vertices are widened into such memory, not read into it.
  /// `normals` as in the overload above. The result's `vertices` is empty.
  DeformResult deform(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt,
                      std::shared_ptr<const double>* vertices, double* normals = nullptr);

  /// #V x 3 vertices of the last frame that succeeded, in the input order (the rest
  /// mesh before any frame, and after set_rest_vertices until the next frame).
  RowMatrixX3d vertices() const;

  /// Moves the rest mesh to X (same faces): the next frame deforms X as a
  /// VulkanDeformer built on it would (embedding, cell order of the tiles, rest
  /// volume), within the backend's float32 tolerance. Only X goes to the device; the
  /// embedding (span and local parameter per vertex) and the sort of the vertices by
  /// lattice cell run there, with the CPU's rules (lattice/embed.h; on periodic axes the
  /// wrap into the box, with a shift seam's translation and a twist seam's mirror, is
  /// done there too). The rest volume is summed on the host in float64 (O(F)) on its
  /// first use (frame/rest_volume.h): a plain frame does not need it. The vertex order of the device buffers
  /// (vertex_order()) and the faces do not change. Not to be called while a frame runs.
  /// The device work is not submitted here: it runs first in the next frame's
  /// submission (one submission and one wait per frame), or alone when vertices() is
  /// read before a frame; until then vertex_buffer_handle()'s buffer holds the last
  /// frame's vertices.
  /// @param[in] X  #V x 3 new rest vertices, world units
  /// @throws InvalidInputError for a wrong shape, non-finite coordinates, vertices too far
  ///         from the lattice, or outside its box (unless built with
  ///         OutsidePolicy::Extrapolate), with the CPU's message (how many, the first),
  ///         or, unlike the CPU, over 2^24 box extents away along a periodic axis (the
  ///         device's float32 positions keep nothing of their place in the box there);
  ///         the deformer is unchanged then. DeviceError when a Vulkan call fails.
  void set_rest_vertices(const Eigen::Ref<const RowMatrixX3d>& X);
  /// Moves the rest mesh by translations, as Deformer::set_rest_offsets: part k's
  /// vertices (the whole mesh's without parts) to their base positions (those of
  /// construction or of the last set_rest_vertices) plus row k of `offsets`. Only
  /// the K offsets go to the device, which adds them to the base positions it keeps
  /// (in its reals: within a real's rounding of the host's float64 sum), embeds and
  /// sorts, first thing in the next frame's submission. The host's work is O(K): the
  /// checks test each part's bounding box (the same refusals as set_rest_vertices,
  /// with its messages), the rest volumes stay the base's (closed mesh or parts), and
  /// rest_vertices() is the float64 sum, made when first read.
  /// @param[in] offsets  K x 3 translations, world units (K = the number of parts, 1 without)
  /// @throws InvalidInputError for a wrong shape, non-finite offsets, or vertices moved
  ///         outside the box (unless OutsidePolicy::Extrapolate); the deformer is
  ///         unchanged then. DeviceError when a Vulkan call fails.
  void set_rest_offsets(const Eigen::Ref<const RowMatrixX3d>& offsets);
  /// The current rest vertices (#V x 3, input order; a copy, so that a move on another
  /// thread cannot change it under the caller).
  RowMatrixX3d rest_vertices() const;
  /// Enclosed volume of the current rest mesh, as Deformer::rest_volume.
  /// @throws InvalidInputError for an open mesh, unless `allow_open`
  double rest_volume(bool allow_open = false) const;
  /// Whether the rest volume is summed already (it is on first use after a move).
  bool rest_volume_known() const;
  /// The rest volume a move to X would give, without moving (Deformer::rest_volume_of).
  double rest_volume_of(const Eigen::Ref<const RowMatrixX3d>& X) const;

  /// Enclosed volume of each part of the current rest mesh (K; the whole mesh's
  /// without parts), as Deformer::rest_part_volumes of a Deformer built on it.
  VectorXd rest_part_volumes() const;

  /// The CPU Deformer of the current rest mesh: edges, embedding, jacobians,
  /// matrices... After set_rest_vertices it is re-embedded on the host on the first
  /// call (frames never need it), so call it outside the frame loop.
  const Deformer& cpu() const;
  const DeviceInfo& device() const;
  /// The precision the device sums in: Float64 or FloatFloat (never Auto).
  Precision precision() const;
  /// Timings of the last frame that ran on the device (a copy: another thread's
  /// frame may replace them at any time).
  FrameTimings last_timings() const;
  /// Reference point of the device positions (the lattice centre), world units.
  const Vector3d& origin() const;
  /// Unit of the device positions: the power of two nearest to the lattice's half
  /// diagonal (keeps every device quantity well inside float32's exponent range).
  double scale() const;

  /// For a renderer on the same VkDevice: the raw VkBuffer handles of the device
  /// vertex buffer (#V x 3 float32, (positions - origin()) / scale(), in the device's vertex
  /// order) and index buffer (#F x 3 int32 in that order), and that order:
  /// device vertex i is input vertex vertex_order()[i].
  std::uint64_t vertex_buffer_handle() const;
  std::uint64_t index_buffer_handle() const;
  const std::vector<std::int32_t>& vertex_order() const;

 private:
  // Records its reconstruction after this deformer's frame, in the same submission.
  friend class VulkanMultires;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vpffd::vulkan
