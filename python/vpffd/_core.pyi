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
__all__: list[str] = ['BackendUnavailableError', 'Deformer', 'DeviceError', 'InvalidInputError', 'LatticeSpec', 'MeshIOError', 'RayScene', 'SolverError', 'VulkanDeformer', 'basis_functions', 'basis_functions_fast', 'bend', 'box_mesh', 'camera_ray', 'check_folds', 'check_mesh', 'clamped_uniform_knots', 'deformed_normals_exact', 'deformed_normals_tangent', 'edge_report', 'ffd_points', 'greville', 'has_embree', 'has_openmesh', 'has_openmp', 'has_vulkan', 'icosphere', 'max_fold_depth', 'max_subcells_per_cell', 'max_threads', 'mesh_formats', 'orient_faces', 'periodic_uniform_knots', 'point_basis_matrix', 'read_mesh', 'require_closed', 'scale', 'signed_volume', 'taper', 'twist', 'validate_mesh', 'vertex_normals', 'vulkan_devices', 'write_mesh']
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
    def tie_sources(self) -> list[int]:
        """
        Per extended control point, the distinct one it copies.
        """
    def wrap_points(self, points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"]) -> tuple:
        """
        (points wrapped into the box along periodic axes, mirrored flags).
        """
    @property
    def seams(self) -> typing.Annotated[list[str], "FixedSize(3)"]:
        ...
    @property
    def distinct_shape(self) -> typing.Annotated[list[int], "FixedSize(3)"]:
        ...
    def parameters(self, points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"]) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        """
        (n, 3) parameters (u, v, w) of world points.
        """
    def rest_control_points(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        """
        (N, 3) control points at the Greville abscissae.
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
    def knots(self) -> typing.Annotated[list[list[float]], "FixedSize(3)"]:
        ...
    @property
    def shape(self) -> typing.Annotated[list[int], "FixedSize(3)"]:
        ...
class Deformer:
    def __init__(self, vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"], lattice: LatticeSpec, outside: str = 'error', threads: typing.SupportsInt | typing.SupportsIndex = 0, parts: str | typing.Annotated[numpy.typing.ArrayLike, numpy.int64, "[m, 1]"] | None = None) -> None:
        ...
    def set_rest_vertices(self, vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> None:
        ...
    def rest_part_volumes(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 1]"]:
        ...
    def basis_matrix(self, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple:
        ...
    def deform(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], preserve_volume: bool = True, axes: str = 'xyz', weights: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[m, 1]"] | None = None, fixed: collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex] | None = None, constraints: collections.abc.Sequence[tuple[typing.SupportsInt | typing.SupportsIndex, typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"]]] = [], target_volume: typing.SupportsFloat | typing.SupportsIndex | None = None, method: str = 'traversal', threads: typing.SupportsInt | typing.SupportsIndex = 0, allow_open: bool = False, rounds: typing.SupportsInt | typing.SupportsIndex = 1, record_timings: bool = False, part_targets: collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex] | None = None) -> dict:
        ...
    def face_matrix(self, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple:
        ...
    def face_matrix_nnz(self, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> int:
        ...
    def ffd(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
    def jacobians(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, n]"]:
        ...
    def rest_volume(self, allow_open: bool = False) -> float:
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
    def rest_vertices(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
    @property
    def vertex_parts(self) -> numpy.typing.NDArray[numpy.int32]:
        ...
class VulkanDeformer:
    def __init__(self, vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"], lattice: LatticeSpec, outside: str = 'error', device: str = '', precision: str = 'auto') -> None:
        ...
    def deform(self, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], preserve_volume: bool = True, axes: str = 'xyz', weights: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[m, 1]"] | None = None, fixed: collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex] | None = None, constraints: collections.abc.Sequence[tuple[typing.SupportsInt | typing.SupportsIndex, typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"]]] = [], target_volume: typing.SupportsFloat | typing.SupportsIndex | None = None, method: str = 'traversal', threads: typing.SupportsInt | typing.SupportsIndex = 0, allow_open: bool = False, rounds: typing.SupportsInt | typing.SupportsIndex = 1, read_vertices: bool = True, normals: bool = False) -> dict:
        ...
    def last_timings(self) -> dict:
        ...
    def vertices(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
    @property
    def cpu(self) -> Deformer:
        """
        The CPU Deformer of the same mesh (rest volume, ffd, jacobians, matrices).
        """
    @property
    def device(self) -> dict:
        ...
    @property
    def index_buffer_handle(self) -> int:
        ...
    @property
    def precision(self) -> str:
        """
        How the device sums: 'float64' or 'float-float'.
        """
    @property
    def origin(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"]:
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
class RayScene:
    """
    A triangle mesh in an Embree scene (picking, rendering).
    """
    def __init__(self, vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"]) -> None:
        ...
    def intersect(self, origins: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], directions: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], tmin: typing.SupportsFloat | typing.SupportsIndex = 0.0) -> tuple[numpy.typing.NDArray[numpy.bool], numpy.typing.NDArray[numpy.int64], numpy.typing.NDArray[numpy.float64], numpy.typing.NDArray[numpy.float64], numpy.typing.NDArray[numpy.float64]]:
        """
        (hit (n,) bool, face (n,) int64, uv (n, 2), distance (n,), point (n, 3)) of the first hits.
        """
    def render(self, eye: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], target: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], up: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], fov: typing.SupportsFloat | typing.SupportsIndex, width: typing.SupportsInt | typing.SupportsIndex, height: typing.SupportsInt | typing.SupportsIndex, samples: typing.SupportsInt | typing.SupportsIndex = 1, background: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"] = ..., base_color: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"] = ..., colors: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[m, 3]"] | None = None, normals: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[m, 3]"] | None = None, points: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[m, 3]"] | None = None, lines: typing.Annotated[numpy.typing.ArrayLike, numpy.int32, "[m, 2]"] | None = None, line_color: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"] = ..., point_color: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"] = ..., point_radius: typing.SupportsFloat | typing.SupportsIndex = 3.0, hidden_alpha: typing.SupportsFloat | typing.SupportsIndex = 0.25) -> tuple[numpy.typing.NDArray[numpy.uint8], numpy.typing.NDArray[numpy.float32]]:
        """
        (image (H, W, 3) uint8, depth (H, W) float32 distances, inf on the background).
        """
    @property
    def n_faces(self) -> int:
        ...
    @property
    def n_vertices(self) -> int:
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
def check_mesh(vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"]) -> dict:
    """
    Defect counts of a triangle mesh (see vpffd/mesh/check.h).
    """
def check_folds(lattice: LatticeSpec, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], depth: typing.SupportsInt | typing.SupportsIndex = 3, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> dict:
    """
    Fold-over check of a lattice: a dict with the verdict, per-cell arrays and the witness.
    """
def periodic_uniform_knots(n: typing.SupportsInt | typing.SupportsIndex, degree: typing.SupportsInt | typing.SupportsIndex, lo: typing.SupportsFloat | typing.SupportsIndex = 0.0, hi: typing.SupportsFloat | typing.SupportsIndex = 1.0) -> list[float]:
    ...
def clamped_uniform_knots(n: typing.SupportsInt | typing.SupportsIndex, degree: typing.SupportsInt | typing.SupportsIndex, lo: typing.SupportsFloat | typing.SupportsIndex = 0.0, hi: typing.SupportsFloat | typing.SupportsIndex = 1.0) -> list[float]:
    ...
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
def ffd_points(lattice: LatticeSpec, control_points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], points: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], outside: str = 'error', threads: typing.SupportsInt | typing.SupportsIndex = 0) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
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
def signed_volume(vertices: typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]", "flags.c_contiguous"], faces: typing.Annotated[numpy.typing.NDArray[numpy.int32], "[m, 3]", "flags.c_contiguous"], origin: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"] = ...) -> float:
    ...
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
    Writes a mesh file; binary -1 = the format's default. Returns split_faces, dropped_faces, vertices_written. Raises MeshIOError.
    """
__version__: str = '0.1.0'
has_embree: bool = True
has_openmesh: bool = True
has_vulkan: bool = True
max_fold_depth: int
max_subcells_per_cell: int
