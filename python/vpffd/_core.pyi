# Type stubs of the compiled module, generated from a full build (Vulkan, OpenMesh, Embree)
# with: .venv/bin/pybind11-stubgen vpffd._core -o /tmp/stubs && cp /tmp/stubs/vpffd/_core.pyi python/vpffd/
"""
vpffd C++ core: volume-preserving B-spline free-form deformation
"""
from __future__ import annotations
import collections.abc
import numpy
import numpy.typing
import typing
__all__: list[str] = ['BackendUnavailableError', 'CorrectionOptions', 'Deformer', 'DeviceError', 'InvalidInputError', 'LatticeSpec', 'MeshIOError', 'Multires', 'MultiresFFD', 'RayScene', 'RbfMap', 'RbfRegions', 'RbfWeights', 'SolverError', 'SubdivAffineGroup', 'SubdivisionMultires', 'VulkanDeformer', 'VulkanMultires', 'VulkanRbfFrame', 'VulkanSubdivFrame', 'basis_functions', 'basis_functions_fast', 'bend', 'box_mesh', 'camera_ray', 'check_folds', 'check_mesh', 'clamped_uniform_knots', 'cone_volumes', 'decimate_mesh', 'deformed_normals_exact', 'deformed_normals_tangent', 'edge_report', 'ffd_points', 'greville', 'has_embree', 'has_mesh_io', 'has_openmesh', 'has_openmp', 'has_opensubdiv', 'has_vulkan', 'icosphere', 'max_fold_depth', 'max_subcells_per_cell', 'max_threads', 'mesh_formats', 'orient_faces', 'periodic_uniform_knots', 'point_basis_matrix', 'read_mesh', 'require_closed', 'scale', 'signed_volume', 'subdivision_decompose', 'subdivision_decompose_decimated', 'taper', 'twist', 'validate_mesh', 'vertex_normals', 'vulkan_devices', 'write_mesh']
class InvalidInputError(ValueError):
    pass
class SolverError(RuntimeError):
    pass
class MeshIOError(OSError):
    pass
class BackendUnavailableError(RuntimeError):
    pass
class DeviceError(RuntimeError):
    pass
class CorrectionOptions:
    """
    The options of one frame, for every backend's deform() (vpffd::CorrectionOptions). Build with keywords: CorrectionOptions(axes='xy', rounds=3, ...).
    """
    def __init__(self, **kwargs) -> None:
        ...
    def __repr__(self) -> str:
        ...
    @property
    def allow_inversion(self) -> bool:
        """
        Accept a target volume of zero or of the other sign than the rest volume (the surface is flattened or turned inside out).
        """
    @allow_inversion.setter
    def allow_inversion(self, arg0: bool) -> None:
        ...
    @property
    def allow_open(self) -> bool:
        """
        Correct the cone volume of a mesh that is not closed.
        """
    @allow_open.setter
    def allow_open(self, arg0: bool) -> None:
        ...
    @property
    def axes(self) -> str:
        """
        Axes the control points move along, in order: 'xyz', 'xy', 'z', ...
        """
    @axes.setter
    def axes(self, arg1: str) -> None:
        ...
    @property
    def constraints(self) -> list[tuple[int, typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"], typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"]]]:
        """
        Point constraints as (vertex, point, target): vertex >= 0 names a mesh vertex, -1 takes the rest-space point; target is where it must go (world units).
        """
    @constraints.setter
    def constraints(self, arg1: collections.abc.Sequence[tuple[typing.SupportsInt | typing.SupportsIndex, typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"]]]) -> None:
        ...
    @property
    def fixed(self) -> list[int] | None:
        """
        None, or 1 per control point that must not move (N,).
        """
    @fixed.setter
    def fixed(self, arg1: collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex] | None) -> None:
        ...
    @property
    def method(self) -> str:
        """
        How the volume coefficients are computed: 'traversal' or 'csr'.
        """
    @method.setter
    def method(self, arg1: str) -> None:
        ...
    @property
    def part_targets(self) -> list[float] | None:
        """
        None (each part keeps its rest volume) or one target volume per part.
        """
    @part_targets.setter
    def part_targets(self, arg1: collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex] | None) -> None:
        ...
    @property
    def preserve_volume(self) -> bool:
        """
        Correct the volume to target_volume (False: plain FFD plus any constraints).
        """
    @preserve_volume.setter
    def preserve_volume(self, arg0: bool) -> None:
        ...
    @property
    def record_timings(self) -> bool:
        """
        Add 'timings' (ms per pass) to the result (CPU backends).
        """
    @record_timings.setter
    def record_timings(self, arg0: bool) -> None:
        ...
    @property
    def rounds(self) -> int:
        """
        Cycles through the axes (1..64).
        """
    @rounds.setter
    def rounds(self, arg1: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def target_volume(self) -> float | None:
        """
        None (the rest volume) or the volume to keep, world units cubed.
        """
    @target_volume.setter
    def target_volume(self, arg1: typing.SupportsFloat | typing.SupportsIndex | None) -> None:
        ...
    @property
    def threads(self) -> int:
        """
        0: all OpenMP threads; 1: serial.
        """
    @threads.setter
    def threads(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def weights(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 1]"] | None:
        """
        None, or one weight > 0 per control point (N,).
        """
    @weights.setter
    def weights(self, arg1: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[m, 1]"] | None) -> None:
        ...
class LatticeSpec:
    """
    Structure of a B-spline lattice: degrees, knots, world box.
    """
    def __init__(self, degree: typing.Annotated[collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex], "FixedSize(3)"], knots: typing.Annotated[collections.abc.Sequence[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex]], "FixedSize(3)"], box_min: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], box_max: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], seams: typing.Annotated[collections.abc.Sequence[str], "FixedSize(3)"] = ['none', 'none', 'none']) -> None:
        ...
    def expand_control_points(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"]) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        """
        (N_ext, 3) extended control points of (N, 3) distinct ones (periodic.h).
        """
    def parameters(self, points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"]) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        """
        (n, 3) parameters (u, v, w) of world points.
        """
    def rest_control_points(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        """
        (N, 3) control points at the Greville abscissae.
        """
    def tie_sources(self) -> list[int]:
        """
        Per extended control point, the distinct one it copies.
        """
    def wrap_points(self, points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"]) -> tuple[typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"], list[int]]:
        """
        (points wrapped into the box along periodic axes, mirrored flags).
        """
    @property
    def box_max(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"]:
        ...
    @property
    def box_min(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"]:
        ...
    @property
    def degree(self) -> typing.Annotated[list[int], "FixedSize(3)"]:
        ...
    @property
    def distinct_shape(self) -> typing.Annotated[list[int], "FixedSize(3)"]:
        ...
    @property
    def knots(self) -> typing.Annotated[list[list[float]], "FixedSize(3)"]:
        ...
    @property
    def seams(self) -> typing.Annotated[list[str], "FixedSize(3)"]:
        ...
    @property
    def shape(self) -> typing.Annotated[list[int], "FixedSize(3)"]:
        ...
class Deformer:
    def __init__(self, vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"], lattice: LatticeSpec, outside: str = 'error', threads: typing.SupportsInt | typing.SupportsIndex = 0, parts: typing.Any = None) -> None:
        ...
    def basis_matrix(self, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple:
        ...
    def basis_transpose(self, values: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 1]"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 1]"]:
        ...
    def deform(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], options: CorrectionOptions = ..., out: typing.Any = None) -> dict:
        """
        One frame (vpffd::Deformer::deform): the result as a dict (vertices, control_points, offsets, volumes, steps, [part volumes], [timings]).
        """
    def deformed_normals(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], rest_normals: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0, out: typing.Any = None) -> typing.Any:
        ...
    def face_matrix(self, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple:
        ...
    def face_matrix_nnz(self, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> int:
        ...
    def ffd(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0, out: typing.Any = None) -> typing.Any:
        ...
    def jacobian_determinants(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 1]"]:
        ...
    def jacobians(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, n]"]:
        ...
    def rest_part_volumes(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 1]"]:
        ...
    def rest_volume(self, allow_open: bool = False) -> float:
        """
        Enclosed volume of the current rest mesh, summed on first use after a move.
        """
    def rest_volume_of(self, vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> float:
        """
        The rest volume set_rest_vertices(vertices) would give (the same sum), without moving.
        """
    def set_rest_offsets(self, offsets: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> None:
        """
        Moves each part (the whole mesh without parts) by its row of offsets (K, 3) from the base positions (see vpffd::Deformer::set_rest_offsets).
        """
    def set_rest_vertices(self, vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> None:
        ...
    def volume_coefficients(self, vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], axis: typing.SupportsInt | typing.SupportsIndex, method: str = 'traversal', threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple[typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 1]"], float]:
        ...
    @property
    def bytes_per_vertex(self) -> float:
        ...
    @property
    def has_parts(self) -> bool:
        ...
    @property
    def is_closed(self) -> bool:
        ...
    @property
    def n_control_points(self) -> int:
        ...
    @property
    def n_faces(self) -> int:
        ...
    @property
    def n_parts(self) -> int:
        ...
    @property
    def n_vertices(self) -> int:
        ...
    @property
    def origin(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"]:
        ...
    @property
    def part_labels(self) -> list[int]:
        ...
    @property
    def rest_is_offset(self) -> bool:
        ...
    @property
    def rest_vertices(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
    @property
    def rest_volume_known(self) -> bool:
        ...
    @property
    def vertex_parts(self) -> numpy.typing.NDArray[numpy.int32]:
        ...
class Multires:
    """
    Two-scale decomposition (base + displacements).
    """
    bytes_per_vertex: typing.ClassVar[int] = 237
    frame_bytes_per_vertex: typing.ClassVar[int] = 128
    def __init__(self, vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"], smoothing: typing.SupportsFloat | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0, exact_foot_points: bool = True, fit_rounds: typing.SupportsInt | typing.SupportsIndex = 4, fairness: typing.SupportsFloat | typing.SupportsIndex = 100.0, lift: bool = True, progress: typing.Any = None) -> None:
        ...
    @property
    def base(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
    @property
    def displacements(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def exact(self) -> numpy.typing.NDArray[numpy.bool]:
        ...
    @property
    def extrapolated_fraction(self) -> float:
        ...
    @property
    def fairness(self) -> float:
        ...
    @property
    def foot_faces(self) -> numpy.typing.NDArray[numpy.int32]:
        ...
    @property
    def foot_points(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def foot_uv(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def lift(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def lifted_count(self) -> int:
        ...
    @property
    def normal_coefficients(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def residuals(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def rest_normals(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
    @property
    def rms_displacement(self) -> list[float]:
        ...
    @property
    def tangents_u(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def tangents_v(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def unresolved_count(self) -> int:
        ...
class MultiresFFD:
    """
    FFD of a decomposition's base, reconstruction of the fine mesh.
    """
    frame_bytes_per_vertex: typing.ClassVar[int] = 140
    def __init__(self, multires: Multires, lattice: LatticeSpec, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> None:
        ...
    def deform(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0, out: typing.Any = None, out_normals: typing.Any = None) -> tuple[typing.Any, typing.Any]:
        """
        (vertices (V, 3), unit normals (V, 3)).
        """
    def deform_per_point(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0, out: typing.Any = None, out_normals: typing.Any = None) -> tuple[typing.Any, typing.Any]:
        """
        deform() with the per-point kernel (its reference): (vertices (V, 3), unit normals (V, 3)).
        """
    def foot_values_jacobians(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple[typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"], typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, n]"]]:
        """
        (D at the foot points (V, 3), Jacobians (V, 9)).
        """
    def foot_values_jacobians_per_point(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple[typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"], typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, n]"]]:
        """
        foot_values_jacobians with the per-point kernel (the reference).
        """
    @property
    def held_bytes_per_vertex(self) -> int:
        ...
    @property
    def uses_cell_runs(self) -> bool:
        ...
class RbfWeights:
    """
    A solved RBF map (normalised coordinates).
    """
    @property
    def A(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 3]"]:
        ...
    @property
    def b(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"]:
        ...
    @property
    def w(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
class RbfMap:
    """
    Triharmonic RBF space deformation, factorised once per handle set.
    """
    def __init__(self, handles: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"]) -> None:
        ...
    def deform(self, multires: Multires, weights: RbfWeights, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple:
        ...
    def jacobians(self, weights: RbfWeights, points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, n]"]:
        """
        (n, 9) row-major Jacobians of the map.
        """
    def map(self, weights: RbfWeights, points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
    def solve(self, targets: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"]) -> RbfWeights:
        ...
    @property
    def handles(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
    @property
    def n_handles(self) -> int:
        ...
class RbfRegions:
    """
    Paper 002 Section 6: deformable region, K handle regions moved by affine maps, the RBF deformation basis precomputed per free vertex.
    """
    def __init__(self, multires: Multires, deformable: typing.Annotated[numpy.typing.ArrayLike, numpy.uint8], handles: collections.abc.Sequence[typing.Annotated[numpy.typing.ArrayLike, numpy.int64]], fixed_rings: typing.SupportsInt | typing.SupportsIndex = 2, spacing: typing.SupportsFloat | typing.SupportsIndex = 0.0, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> None:
        ...
    def deform(self, transforms: collections.abc.Sequence[typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[4, 4]"]], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple[typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"], typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"], typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]]:
        """
        (vertices (V, 3), unit normals (V, 3), base vertices (V, 3)) for K (4, 4) affine transforms.
        """
    def targets(self, transforms: collections.abc.Sequence[typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[4, 4]"]]) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        """
        (H, 3) constraint targets of the K (4, 4) transforms.
        """
    @property
    def basis(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, n]"]:
        """
        (n_free, 16 K) the precomputed basis of the free vertices (labels == 0, ascending).
        """
    @property
    def constraint_points(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
    @property
    def constraint_regions(self) -> numpy.typing.NDArray[numpy.int32]:
        ...
    @property
    def constraint_vertices(self) -> numpy.typing.NDArray[numpy.int64]:
        ...
    @property
    def doubles_per_free_vertex(self) -> int:
        ...
    @property
    def labels(self) -> numpy.typing.NDArray[numpy.int32]:
        ...
    @property
    def n_free(self) -> int:
        ...
    @property
    def n_regions(self) -> int:
        ...
class VulkanDeformer:
    def __init__(self, vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"], lattice: LatticeSpec, outside: str = 'error', device: str = '', precision: str = 'auto', parts: typing.Any = None) -> None:
        ...
    def deform(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], options: CorrectionOptions = ..., read_vertices: bool = True, normals: bool = False, out: typing.Any = None, out_normals: typing.Any = None) -> dict:
        """
        One frame (see vpffd::vulkan::VulkanDeformer::deform), the options as for Deformer.deform. normals=True adds 'normals': the (V, 3) unit normals of the deformed surface, computed on the device in the same submission.
        """
    def last_timings(self) -> dict:
        ...
    def rest_part_volumes(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 1]"]:
        """
        (K,) each part's volume of the current rest mesh (the whole mesh's without parts).
        """
    def rest_volume(self, allow_open: bool = False) -> float:
        """
        Enclosed volume of the current rest mesh (raises for an open mesh unless allow_open), summed on the host on first use after a move.
        """
    def rest_volume_of(self, vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"]) -> float:
        """
        The rest volume set_rest_vertices(vertices) would give (the same sum), without moving.
        """
    def set_rest_offsets(self, offsets: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"]) -> None:
        """
        Moves each part (the whole mesh without parts) by its row of offsets (K, 3) from the base positions: only the offsets go to the device (see vpffd::vulkan::VulkanDeformer::set_rest_offsets).
        """
    def set_rest_vertices(self, vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"]) -> None:
        """
        Moves the rest mesh (V, 3): embedded and sorted by cell on the device (see vpffd::vulkan::VulkanDeformer::set_rest_vertices).
        """
    def vertices(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
    @property
    def cpu(self) -> Deformer:
        """
        The CPU Deformer of the current rest mesh (ffd, jacobians, matrices); after set_rest_vertices the first access re-embeds it on the host.
        """
    @property
    def device(self) -> dict:
        ...
    @property
    def index_buffer_handle(self) -> int:
        ...
    @property
    def origin(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"]:
        ...
    @property
    def precision(self) -> str:
        """
        How the device sums: 'float64' or 'float-float'.
        """
    @property
    def rest_vertices(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        """
        (V, 3) the current rest vertices (a copy).
        """
    @property
    def rest_volume_known(self) -> bool:
        ...
    @property
    def scale(self) -> float:
        """
        Unit of the device positions: (world - origin) / scale (a power of two).
        """
    @property
    def vertex_buffer_handle(self) -> int:
        ...
    @property
    def vertex_order(self) -> numpy.typing.NDArray[numpy.int32]:
        ...
class VulkanMultires:
    """
    The multiresolution frame of a decomposition's base FFD on a Vulkan device.
    """
    frame_bytes_per_vertex: typing.ClassVar[int] = 76
    def __init__(self, multires: Multires, lattice: LatticeSpec, device: str = '', precision: str = 'auto') -> None:
        ...
    def deform(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], out: typing.Any = None, out_normals: typing.Any = None) -> tuple[typing.Any, typing.Any]:
        """
        (vertices (V, 3), approximate unit normals (V, 3)), input order.
        """
    def deform_after(self, correction: VulkanDeformer, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], options: CorrectionOptions, base: VulkanDeformer = None, out: typing.Any = None, out_normals: typing.Any = None) -> tuple[typing.Any, typing.Any, typing.Any, dict]:
        """
        One submission: correction's frame (as VulkanDeformer.deform), then the reconstruction from its corrected control points (and, with base, the base Deformer's FFD of them): (vertices, normals, base vertices, the correction's result dict without 'vertices').
        """
    def last_timings(self) -> dict:
        ...
    @property
    def device(self) -> dict:
        ...
    @property
    def normal_buffer_handle(self) -> int:
        ...
    @property
    def origin(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"]:
        ...
    @property
    def precision(self) -> str:
        ...
    @property
    def scale(self) -> float:
        ...
    @property
    def vertex_buffer_handle(self) -> int:
        ...
    @property
    def vertex_order(self) -> numpy.typing.NDArray[numpy.int32]:
        ...
class VulkanSubdivFrame:
    """
    The frame of a displaced subdivision surface on a Vulkan device, from the decomposition's plain arrays (SubdivisionMultires.stencils, displacements, normal_coefficients).
    """
    def __init__(self, indptr: typing.Annotated[numpy.typing.ArrayLike, numpy.int64], indices: typing.Annotated[numpy.typing.ArrayLike, numpy.int32], w: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], wu: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], wv: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], displacements: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], normal_coefficients: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], rest_control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], device: str = '', precision: str = 'auto') -> None:
        ...
    def deform(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"]) -> tuple[typing.Any, typing.Any, typing.Any]:
        """
        (vertices (V, 3), approximate unit normals (V, 3), limit points S'(t_i) (V, 3)), as SubdivisionMultires.deform.
        """
    def last_timings(self) -> dict:
        ...
    @property
    def device(self) -> dict:
        ...
    @property
    def n_control(self) -> int:
        ...
    @property
    def n_vertices(self) -> int:
        ...
    @property
    def origin(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"]:
        ...
    @property
    def precision(self) -> str:
        ...
    @property
    def scale(self) -> float:
        ...
class VulkanRbfFrame:
    """
    The RBF regions frame (Marinov et al. §6) on a Vulkan device, from an RbfRegions setting.
    """
    def __init__(self, regions: RbfRegions, device: str = '', precision: str = 'auto') -> None:
        ...
    def deform(self, transforms: collections.abc.Sequence[typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[4, 4]"]]) -> tuple[typing.Any, typing.Any, typing.Any]:
        """
        (vertices (V, 3), unit normals (V, 3), base vertices (V, 3)) for K (4, 4) affine maps, as RbfRegions.deform.
        """
    def last_timings(self) -> dict:
        ...
    @property
    def device(self) -> dict:
        ...
    @property
    def n_free(self) -> int:
        ...
    @property
    def n_regions(self) -> int:
        ...
    @property
    def n_vertices(self) -> int:
        ...
    @property
    def origin(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"]:
        ...
    @property
    def precision(self) -> str:
        ...
    @property
    def scale(self) -> float:
        ...
class RayScene:
    """
    A triangle mesh in an Embree scene (picking, rendering).
    """
    def __init__(self, vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"], fast_build: bool = False, refit: bool = False) -> None:
        ...
    def intersect(self, origins: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], directions: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], tmin: typing.SupportsFloat | typing.SupportsIndex = 0.0) -> tuple[numpy.typing.NDArray[numpy.bool], numpy.typing.NDArray[numpy.int64], numpy.typing.NDArray[numpy.float64], numpy.typing.NDArray[numpy.float64], numpy.typing.NDArray[numpy.float64]]:
        """
        (hit (n,) bool, face (n,) int64, uv (n, 2), distance (n,), point (n, 3)) of the first hits.
        """
    def render(self, eye: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], target: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], up: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], fov: typing.SupportsFloat | typing.SupportsIndex, width: typing.SupportsInt | typing.SupportsIndex, height: typing.SupportsInt | typing.SupportsIndex, samples: typing.SupportsInt | typing.SupportsIndex = 1, background: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"] = ..., base_color: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"] = ..., colors: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[m, 3]"] | None = None, normals: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[m, 3]"] | None = None, points: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[m, 3]"] | None = None, lines: typing.Annotated[numpy.typing.ArrayLike, numpy.int32, "[m, 2]"] | None = None, line_color: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"] = ..., point_color: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"] = ..., point_radius: typing.SupportsFloat | typing.SupportsIndex = 3.0, hidden_alpha: typing.SupportsFloat | typing.SupportsIndex = 0.25, line_alpha: typing.SupportsFloat | typing.SupportsIndex = 1.0, line_width: typing.SupportsFloat | typing.SupportsIndex = 1.0, adaptive: bool = True) -> tuple[numpy.typing.NDArray[numpy.uint8], numpy.typing.NDArray[numpy.float32]]:
        """
        (image (H, W, 3) uint8, depth (H, W) float32 distances, inf on the background).
        """
    def set_vertices(self, vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"]) -> None:
        """
        Moves the vertices (same count, same faces); refits the BVH of a scene built with refit=True.
        """
    @property
    def n_faces(self) -> int:
        ...
    @property
    def n_vertices(self) -> int:
        ...
class SubdivisionMultires:
    """
    Displaced subdivision surface: limit surface of a control mesh + displacements.
    """
    def affine_group(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], indices: collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> ...:
        ...
    def deform(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple:
        """
        (vertices (V, 3), approximate unit normals (V, 3), base points S'(t_i) (V, 3)).
        """
    def deform_affine(self, group: ..., transform: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[4, 4]"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple:
        ...
    @property
    def control_face_sizes(self) -> numpy.typing.NDArray[numpy.int32]:
        ...
    @property
    def control_faces(self) -> numpy.typing.NDArray[numpy.int32]:
        ...
    @property
    def control_points(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
    @property
    def diagonal(self) -> float:
        ...
    @property
    def displacements(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def frame_bytes_per_vertex(self) -> float:
        ...
    @property
    def normal_coefficients(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def patches(self) -> numpy.typing.NDArray[numpy.int32]:
        ...
    @property
    def residuals(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def rest_normals(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
    @property
    def rms_final(self) -> float:
        ...
    @property
    def rms_initial(self) -> float:
        ...
    @property
    def rms_rounds(self) -> list[float]:
        ...
    @property
    def scheme(self) -> str:
        ...
    @property
    def seconds(self) -> float:
        ...
    @property
    def stencils(self) -> tuple[numpy.typing.NDArray[numpy.int64], numpy.typing.NDArray[numpy.int32], numpy.typing.NDArray[numpy.float64], numpy.typing.NDArray[numpy.float64], numpy.typing.NDArray[numpy.float64]]:
        ...
    @property
    def unresolved(self) -> numpy.typing.NDArray[numpy.int32]:
        ...
    @property
    def uv(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
class SubdivAffineGroup:
    """
    A control-point group with its basis precomputed per fine vertex.
    """
    @property
    def bytes_per_vertex(self) -> float:
        ...
    @property
    def indices(self) -> numpy.typing.NDArray[numpy.int32]:
        ...
    @property
    def rows(self) -> numpy.typing.NDArray[numpy.int32]:
        ...
def basis_functions(knots: collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], degree: typing.SupportsInt | typing.SupportsIndex, u: collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], derivatives: bool = False) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, n]"]:
    """
    Dense (len(u), n) matrix of B-spline basis values (or first derivatives) by Cox-de Boor.
    """
def basis_functions_fast(knots: collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], degree: typing.SupportsInt | typing.SupportsIndex, u: collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex]) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, n]"]:
    ...
def bend(points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], angle: typing.SupportsFloat | typing.SupportsIndex, axis: typing.SupportsInt | typing.SupportsIndex, toward: typing.SupportsInt | typing.SupportsIndex, center: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], lo: typing.SupportsFloat | typing.SupportsIndex = 0.0, hi: typing.SupportsFloat | typing.SupportsIndex = 0.0) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
    ...
def box_mesh(n: typing.SupportsInt | typing.SupportsIndex, size: typing.SupportsFloat | typing.SupportsIndex = 1.0) -> tuple[typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"], typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]"]]:
    ...
def camera_ray(eye: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], target: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], up: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], fov: typing.SupportsFloat | typing.SupportsIndex, width: typing.SupportsInt | typing.SupportsIndex, height: typing.SupportsInt | typing.SupportsIndex, x: typing.SupportsFloat | typing.SupportsIndex, y: typing.SupportsFloat | typing.SupportsIndex) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"]:
    """
    Unit direction of the ray through the centre of pixel (x, y).
    """
def check_folds(lattice: LatticeSpec, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], depth: typing.SupportsInt | typing.SupportsIndex = 3, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> dict:
    """
    Fold-over check of a lattice: a dict with the verdict, per-cell arrays and the witness.
    """
def check_mesh(vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"]) -> dict:
    """
    Defect counts of a triangle mesh (see vpffd/mesh/check.h).
    """
def clamped_uniform_knots(n: typing.SupportsInt | typing.SupportsIndex, degree: typing.SupportsInt | typing.SupportsIndex, lo: typing.SupportsFloat | typing.SupportsIndex = 0.0, hi: typing.SupportsFloat | typing.SupportsIndex = 1.0) -> list[float]:
    ...
def cone_volumes(vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"], origin: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], check: bool = True) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 1]"]:
    ...
def decimate_mesh(vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"], target: typing.SupportsInt | typing.SupportsIndex) -> tuple[typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"], typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]"]]:
    """
    (control points (M, 3), triangles) by quadric decimation to about `target` vertices.
    """
def deformed_normals_exact(jacobians: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, n]", "flags.c_contiguous"], rest_normals: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
    """
    (V, 3) unit normals cof(J) n0 / |cof(J) n0| from (V, 9) row-major Jacobians.
    """
def deformed_normals_tangent(lattice: LatticeSpec, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], rest_normals: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], eps: typing.SupportsFloat | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
    """
    (V, 3) unit normals by mapped tangents (finite differences, step eps).
    """
def edge_report(faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"]) -> dict:
    ...
def ffd_points(lattice: LatticeSpec, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], outside: str = 'error', threads: typing.SupportsInt | typing.SupportsIndex = 0, out: typing.Any = None) -> typing.Any:
    ...
def greville(arg0: collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], arg1: typing.SupportsInt | typing.SupportsIndex, arg2: typing.SupportsInt | typing.SupportsIndex) -> list[float]:
    ...
def has_openmp() -> bool:
    """
    True when the CPU kernels were compiled with OpenMP.
    """
def icosphere(subdivisions: typing.SupportsInt | typing.SupportsIndex, radius: typing.SupportsFloat | typing.SupportsIndex = 1.0) -> tuple[typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"], typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]"]]:
    ...
def max_threads() -> int:
    """
    Threads the OpenMP backend uses by default.
    """
def mesh_formats() -> list[str]:
    """
    File extensions read_mesh/write_mesh accept.
    """
def orient_faces(vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"]) -> tuple[typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]"], int, int, int]:
    """
    (faces, flipped_faces, conflicts, inward_components): consistent winding, closed components outward.
    """
def periodic_uniform_knots(n: typing.SupportsInt | typing.SupportsIndex, degree: typing.SupportsInt | typing.SupportsIndex, lo: typing.SupportsFloat | typing.SupportsIndex = 0.0, hi: typing.SupportsFloat | typing.SupportsIndex = 1.0) -> list[float]:
    ...
def point_basis_matrix(lattice: LatticeSpec, points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], outside: str = 'error') -> tuple:
    ...
def read_mesh(path: str) -> dict:
    """
    Reads a mesh file: dict with vertices (V, 3) float64, faces (F, 3) int32, normals (V, 3) or None, polygons, triangulated_polygons, skipped_faces, format, gzipped. Raises MeshIOError.
    """
def require_closed(arg0: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"], arg1: str) -> None:
    ...
def scale(points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], factors: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], center: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"]) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
    ...
def signed_volume(vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"], origin: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"] = ..., check: bool = True) -> float:
    ...
def subdivision_decompose(vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"], control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], face_sizes: collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex], face_vertices: collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex], scheme: str, fairness: typing.SupportsFloat | typing.SupportsIndex, iterations: typing.SupportsInt | typing.SupportsIndex, approx_level: typing.SupportsInt | typing.SupportsIndex, max_unresolved: typing.SupportsInt | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0, progress: typing.Any = None) -> SubdivisionMultires:
    """
    Decomposition over a given control mesh (polygons as sizes + concatenated vertices).
    """
def subdivision_decompose_decimated(vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"], control_vertices: typing.SupportsInt | typing.SupportsIndex, scheme: str, fairness: typing.SupportsFloat | typing.SupportsIndex, iterations: typing.SupportsInt | typing.SupportsIndex, approx_level: typing.SupportsInt | typing.SupportsIndex, max_unresolved: typing.SupportsInt | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0, progress: typing.Any = None) -> SubdivisionMultires:
    """
    Decomposition over a control mesh decimated from the fine one.
    """
def taper(points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], factor: typing.SupportsFloat | typing.SupportsIndex, axis: typing.SupportsInt | typing.SupportsIndex, center: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], lo: typing.SupportsFloat | typing.SupportsIndex = 0.0, hi: typing.SupportsFloat | typing.SupportsIndex = 0.0) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
    ...
def twist(points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], angle: typing.SupportsFloat | typing.SupportsIndex, axis: typing.SupportsInt | typing.SupportsIndex, center: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], lo: typing.SupportsFloat | typing.SupportsIndex = 0.0, hi: typing.SupportsFloat | typing.SupportsIndex = 0.0) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
    ...
def validate_mesh(vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"]) -> None:
    ...
def vertex_normals(vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
    """
    (V, 3) unit area-weighted vertex normals.
    """
def vulkan_devices() -> tuple[list, str]:
    """
    ([device dicts], why): the Vulkan devices, and why there are none when the list is empty.
    """
def write_mesh(path: str, vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"], normals: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[m, 3]"] | None = None, binary: typing.SupportsInt | typing.SupportsIndex = -1, precision: typing.SupportsInt | typing.SupportsIndex = 17) -> dict:
    """
    Writes a mesh file; binary -1 = the format's default. Returns split_faces and dropped_faces (non-zero only for .om, whose halfedge structure cannot hold every mesh as given) and vertices_written. Raises MeshIOError; BackendUnavailableError for .om in a build without OpenMesh.
    """
__version__: str = '0.1.0'
has_embree: bool = True
has_mesh_io: bool = True
has_openmesh: bool = True
has_opensubdiv: bool = True
has_vulkan: bool = True
max_fold_depth: int = 10
max_subcells_per_cell: int = 4096
