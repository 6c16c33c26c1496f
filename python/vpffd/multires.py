"""Multiresolution deformation (Marinov, Botsch and Kobbelt, *GPU-Based Multiresolution
Deformation Using Approximate Normal Field Reconstruction*): a detailed mesh
as a smooth base surface plus normal displacements, deformed through its base
by an FFD lattice or a triharmonic RBF map, with positions and normals rebuilt
per vertex without neighbours (eq. 1 and the approximate normals of eqs. 6-7).

>>> import vpffd
>>> mesh = vpffd.shapes.bumpy_sphere(3)
>>> mr = vpffd.Multires(mesh, smoothing=10)
>>> lat = vpffd.Lattice.around(mesh, shape=6)
>>> r = vpffd.MultiresDeformer(mr, lat).deform(vpffd.twist(lat.control_points, 30))
>>> r.vertices.shape == mesh.vertices.shape
True

Frames run on the CPU (OpenMP or serial) or, for ``MultiresDeformer``, on a Vulkan
device (``backend="vulkan"``: one compute dispatch, in the same submission as the
volume correction, rebuilds positions and approximate normals from the foot points'
embedding, S_u, S_v, d and the six coefficients, uploaded once; see
``MultiresDeformer``). ``RBFDeformer`` (``rbf.py``) runs on the
CPU.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import logging
import threading
import time
import warnings

from . import _arrays, _core
from ._spare import Spares
from ._stages import stage_reporter
from .backends import _requested_precision, _resolve_backend
from .deformer import Deformer, correction_arrays
from .lattice import Lattice
from .mesh import Mesh

InvalidInputError = _core.InvalidInputError
BackendUnavailableError = _core.BackendUnavailableError

_log = logging.getLogger(__name__)

_VOLUME_MODES = ("base", "fine")
_NORMAL_MODES = ("approximate", "exact")


def _threads_arg(threads):
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, (int, np.integer))
                                or not 1 <= threads <= 4096):
        raise InvalidInputError(f"threads: expected an integer in 1..4096 or None, got {threads!r}")
    return 0 if threads is None else int(threads)


def _read_only(a) -> np.ndarray:
    a = np.asarray(a)
    a.setflags(write=False)
    return a


def _volume(V, F, closed: bool) -> float:
    """Enclosed volume of a frame's result: V from the core, F the checked Multires
    mesh's faces (not validated again: a serial check costs as much as the sum)."""
    if not closed:
        return float("nan")
    lo, hi = _arrays.bounds(V)
    return float(_core.signed_volume(V, F, 0.5 * (lo + hi), False))


def _relative(v, ref) -> float:
    if not np.isfinite(ref):
        return float("nan")
    return abs(v - ref) / abs(ref) if ref != 0 else (0.0 if v == 0 else float("inf"))


class Multires:
    """Two-scale decomposition of a triangle mesh: base surface + normal displacements.

    The base S is a smooth triangle mesh with the same connectivity (paper §6) and a
    continuous normal field: on each base triangle, S is the linear patch and N_S the
    normalised interpolation of the base's vertex normals (Phong normals). Every
    fine vertex p gets an *exact* foot point t on S, p - S(t) parallel to N_S(t)
    (eq. 1), found by Newton steps on the triangles of its one-ring and a walk across
    neighbouring triangles; it is stored as p = S(t) + d N_S(t). Neighbouring
    vertices thus get neighbouring foot points and displacement directions, and a
    deformation moves them alike: a face does not turn over because its corners
    were measured from different, discontinuous frames.

    The base starts as the mesh faired by implicit cotangent-Laplacian smoothing and
    is then *fitted* to the mesh (§4.1): ``fit_rounds`` rounds of least squares
    (the foot points' distance to their vertices, plus ``fairness`` times a
    thin-plate energy of the base), each followed by new foot points. Vertices
    still without an exact foot point pull harder in the next round. Fitting
    shortens the displacements about tenfold on scans; with long displacements the
    offset surface folds in concave, thin or noisy parts under large edits.

    A vertex for which no exact foot point exists (the normals of the base cross
    before they reach it) is counted in ``n_unresolved`` and listed in
    ``unresolved``: it keeps the nearest foot point the search found, with the
    tangential miss in ``residuals``. Its position is still rebuilt exactly by the
    identity and rigid motions.

    Where the fine faces are not the graph of their displacements over their foot
    triangles (slivers, faces whose foot points fall out of order: noise and thin
    parts of scans), a shear of a few degrees would turn them over while the space
    map keeps them. With ``lift`` (default), such vertices hand part of their
    displacement to the base deformation: d becomes (1 - w) d with the foot point
    lifted by w d along the normal, so that a frame rebuilds p' = D(p - d' N) + d' N'
    (w = 1 is the plain space map). w is the least that keeps every face's
    first-order area change under a shear of 3 (a 90 degree twist or a 60 % squash)
    from turning it, without making any face more sensitive than it was; faces that
    are height fields are never touched. On scans 0.5 % to 5 % of the vertices are
    lifted (``lift``, ``n_lifted``); identity and rigid motions stay exact.

    Parameters
    ----------
    mesh : Mesh, (vertices, faces) pair, or object with vertices/faces
        any triangle mesh; ``MultiresDeformer.deform(preserve_volume=True)`` needs
        a closed one. Every vertex must be in a triangle.
    smoothing : float > 0
        diffusion time of the fairing in units of the squared mean edge length,
        taken in ceil(smoothing) implicit steps: an integer is a number of unit
        steps (default 10). More smoothing gives a smoother base, larger
        displacements and (paper §4.1) larger approximate-normal errors.
    fit_rounds : int in 0..100
        rounds of fitting the base to the mesh (default 4; 0: the faired base).
    fairness : float > 0
        weight of the base's thin-plate energy against the distances in the fit,
        relative (independent of units and mesh size; default 100). Smaller: the base
        follows the mesh more closely (shorter displacements, less smooth base).
    lift : bool
        shorten the displacements a shear would turn over (default True; see above;
        exact foot points only).
    foot_points : {"exact", "affine"}
        "exact" (default) as above; "affine" stores every vertex in the affine frame
        of the one-ring triangle that needs the least extrapolation, with the
        triangle's own normal (discontinuous from triangle to triangle; kept for
        comparison).
    threads : int, optional
    progress : callable, optional
        called as ``progress(done, total)`` after each stage of the decomposition
        (fairing with the first foot points, each fit round, the lift), from the
        calling thread; each stage is also logged at INFO level (``logging``, logger
        ``vpffd``). An exception it raises stops the decomposition and propagates.

    Attributes
    ----------
    mesh : Mesh
    base : Mesh
        the base surface S (same faces).
    displacements : (V,) float64
        signed normal displacement d_i a frame uses, world units (after the lift).
    lift : (V,) float64
        fraction in [0, 1] of each vertex's displacement carried by the base
        deformation instead (0 almost everywhere); ``n_lifted`` counts those > 0.
    exact : (V,) bool
        True where the foot point is exact: tangential residual at most 1e-9 of
        the bounding-box diagonal.
    residuals : (V,) float64
        world units: where exact, the tangential residual of the foot point
        (rounding, ~1e-16 of the diagonal); elsewhere how far p - S(t) misses the
        normal N_S(t) (or, with ``foot_points="affine"``, how far the affine foot
        point lies outside its triangle).
    n_unresolved : int
        vertices without an exact foot point; ``unresolved`` their indices.
    extrapolated_fraction : float
        n_unresolved / V.
    rms_displacement : tuple of float
        RMS of |d| (world units) of the faired base, then after each fit round.
    seconds : float
        time the decomposition took.
    bytes_per_vertex : int
        per-vertex data held (237 bytes; ``frame_bytes_per_vertex``, 128, is what a
        frame reads).
    """

    bytes_per_vertex = _core.Multires.bytes_per_vertex
    frame_bytes_per_vertex = _core.Multires.frame_bytes_per_vertex

    def __init__(self, mesh, smoothing=10, fit_rounds=4, fairness=100.0, foot_points="exact", threads=None,
                 lift=True, progress=None):
        self.mesh = Mesh.from_any(mesh)
        self.smoothing = _arrays.positive(smoothing, "smoothing", "Multires")
        if isinstance(fit_rounds, bool) or not isinstance(fit_rounds, (int, np.integer)) or not 0 <= fit_rounds <= 100:
            raise InvalidInputError(f"Multires: fit_rounds must be an integer in 0..100, got {fit_rounds!r}")
        self.fit_rounds = int(fit_rounds)
        self.fairness = _arrays.positive(fairness, "fairness", "Multires")
        if foot_points not in ("exact", "affine"):
            raise InvalidInputError(f"Multires: foot_points must be 'exact' or 'affine', got {foot_points!r}")
        self.foot_point_mode = foot_points
        if not isinstance(lift, (bool, np.bool_)):
            raise InvalidInputError(f"Multires: lift must be True or False, got {lift!r}")
        t0 = time.perf_counter()
        _log.info("Multires: decomposing %d vertices (smoothing %g, %d fit rounds, %s foot points)",
                  self.mesh.n_vertices, self.smoothing, self.fit_rounds, foot_points)
        stage = stage_reporter("Multires", "rms |d|", progress, _log)

        self._m = _core.Multires(self.mesh.vertices, self.mesh.faces, self.smoothing, _threads_arg(threads),
                                 foot_points == "exact", self.fit_rounds, self.fairness, bool(lift), stage)
        self.seconds = time.perf_counter() - t0
        self.base = Mesh(self._m.base, self.mesh.faces)
        self.displacements = _read_only(self._m.displacements)
        self.residuals = _read_only(self._m.residuals)
        self.exact = _read_only(self._m.exact)
        self.lift = _read_only(self._m.lift)
        self.n_lifted = int(self._m.lifted_count)
        self.unresolved = _read_only(np.flatnonzero(~self.exact))
        self.n_unresolved = int(self.unresolved.size)
        self.rest_normals = _read_only(self._m.rest_normals)
        self.extrapolated_fraction = float(self._m.extrapolated_fraction)
        self.rms_displacement = tuple(float(x) for x in self._m.rms_displacement)
        _log.info("Multires: decomposed in %.2f s; rms |d| %.4g -> %.4g; %d foot points unresolved; %d lifted",
                  self.seconds, self.rms_displacement[0], self.rms_displacement[-1], self.n_unresolved,
                  self.n_lifted)
        # Reference volumes of every frame's report, measured once (NaN when open).
        closed = self.mesh.is_closed
        self._rest_volumes = (_volume(self.mesh.vertices, self.mesh.faces, closed),
                              _volume(self.base.vertices, self.mesh.faces, closed), closed)

    @property
    def n_vertices(self) -> int:
        return self.mesh.n_vertices

    def frame_data(self) -> dict:
        """Copies of the per-vertex frame data: ``foot_points`` (V, 3), ``tangents_u``,
        ``tangents_v`` (V, 3), ``displacements`` (V,), ``normal_coefficients`` (V, 6)
        (a_u, b_u, g_u, a_v, b_v, g_v), and the bookkeeping ``foot_faces`` (V,) and
        ``foot_uv`` (V, 2)."""
        m = self._m
        return {"foot_points": m.foot_points, "tangents_u": m.tangents_u, "tangents_v": m.tangents_v,
                "displacements": m.displacements, "normal_coefficients": m.normal_coefficients,
                "foot_faces": m.foot_faces, "foot_uv": m.foot_uv}

    def __repr__(self) -> str:
        d = np.abs(self.displacements)
        fit = (f"fitted {self.fit_rounds}x (fairness {self.fairness:g}): rms |d| "
               f"{self.rms_displacement[0]:.3g} -> {self.rms_displacement[-1]:.3g}" if self.fit_rounds else "not fitted")
        if self.n_unresolved:
            first = ", ".join(str(i) for i in self.unresolved[:5]) + (", ..." if self.n_unresolved > 5 else "")
            feet = (f"{self.foot_point_mode} foot points: {self.n_unresolved} unresolved (residual max "
                    f"{self.residuals[self.unresolved].max():.3g}; vertices {first})")
        else:
            feet = f"{self.foot_point_mode} foot points: all resolved"
        if self.n_lifted:
            feet += f", {self.n_lifted} lifted (mean {self.lift[self.lift > 0].mean():.2f})"
        return (f"Multires({self.n_vertices} vertices, smoothing={self.smoothing:g}, {fit}, "
                f"|d| max {d.max():.3g} mean {d.mean():.3g}, {feet}, "
                f"{self.bytes_per_vertex} B/vertex, {self.seconds:.2f} s)")


@dataclass
class MultiresResult:
    """One multiresolution frame.

    Attributes
    ----------
    vertices : (V, 3) float64
        deformed fine vertices p' = S'(t_i) + d_i N_S'.
    normals : (V, 3) float64
        unit normals: eqs. 6-7 ("approximate") or the area-weighted normals of the
        deformed fine mesh ("exact").
    base_vertices : (V, 3) float64
        the deformed base mesh.
    control_points : (nu, nv, nw, 3) or None
        the (corrected) control points that drove the frame; None for an RBF.
    volume, rest_volume, volume_error : float
        enclosed volume of the deformed fine mesh, of the rest one, and
        |volume - rest_volume| / |rest_volume| (NaN for an open mesh).
    base_volume, base_rest_volume, base_volume_error : float
        the same for the base mesh.
    volume_mode, normals_mode, backend : str
    faces : (F, 3) int32 or None
        the fine mesh's faces (shared by ``vertices`` and ``base_vertices``).
    constraint_error : float
        with ``constraints``: the largest distance (world units) between a
        constraint's target and the lattice map's image of its source; NaN without.
    """
    vertices: np.ndarray
    normals: np.ndarray
    base_vertices: np.ndarray
    control_points: object
    volume: float
    rest_volume: float
    volume_error: float
    base_volume: float
    base_rest_volume: float
    base_volume_error: float
    volume_mode: str
    normals_mode: str
    backend: str
    faces: object = None
    constraint_error: float = float("nan")

    def __repr__(self) -> str:
        cp = "RBF map" if self.control_points is None else \
            f"lattice {'x'.join(map(str, np.shape(self.control_points)[:-1]))}"
        cons = "" if not np.isfinite(self.constraint_error) else \
            f"; constraints met to {self.constraint_error:.1e}"
        return (f"MultiresResult({self.vertices.shape[0]} vertices, {cp}, backend {self.backend!r}, "
                f"{self.normals_mode} normals, volume mode {self.volume_mode!r}\n"
                f"  volume {self.volume:.6g} (rest {self.rest_volume:.6g}, relative error {self.volume_error:.1e}); "
                f"base {self.base_volume:.6g} (rest {self.base_rest_volume:.6g}, relative error "
                f"{self.base_volume_error:.1e}){cons})")

    def to_trimesh(self, base: bool = False):
        """The rebuilt fine mesh (or, ``base=True``, the deformed base) as a
        ``trimesh.Trimesh``: vertex order kept, the fine faces; needs trimesh."""
        if self.faces is None:
            raise InvalidInputError("to_trimesh: this result carries no faces")
        if not isinstance(base, (bool, np.bool_)):
            raise TypeError(f"to_trimesh: base: expected a bool, got {type(base).__name__}")
        from .interop import to_trimesh
        return to_trimesh(self.base_vertices if base else self.vertices, self.faces)


def _result(mr: Multires, X, N, B, normals, control_points, volume_mode, backend, out_normals=None,
            constraint_error=float("nan")) -> MultiresResult:
    F = mr.mesh.faces
    if normals == "exact":
        N = _core.vertex_normals(X, F)
        if out_normals is not None:
            out_normals[...] = N
            N = out_normals
    rest, brest, closed = mr._rest_volumes
    vol, bvol = _volume(X, F, closed), _volume(B, F, closed)
    return MultiresResult(vertices=X, normals=N, base_vertices=B, control_points=control_points, volume=vol,
                          rest_volume=rest, volume_error=_relative(vol, rest), base_volume=bvol,
                          base_rest_volume=brest, base_volume_error=_relative(bvol, brest), volume_mode=volume_mode,
                          normals_mode=normals, backend=backend, faces=F, constraint_error=constraint_error)


def _check_normals(normals):
    if normals not in _NORMAL_MODES:
        raise InvalidInputError(f"normals: expected 'approximate' or 'exact', got {normals!r}")


def _correction_options(deformer, P, axes, weights, fixed, rounds, threads):
    """The options ``deformer.deform(P, axes=, weights=, fixed=, rounds=)`` runs with,
    checked as it checks them (for a frame that the device continues)."""
    if not isinstance(axes, str):
        raise TypeError(f"axes: expected a string such as 'xyz', got {type(axes).__name__}")
    if isinstance(rounds, bool) or not isinstance(rounds, (int, np.integer)):
        raise TypeError(f"rounds: expected an integer, got {type(rounds).__name__}")
    w, fx = correction_arrays(deformer, P, weights, fixed)
    return _core.CorrectionOptions(preserve_volume=True, axes=axes, weights=w, fixed=fx, threads=threads,
                                   rounds=int(rounds))


def _check_multires(mr, who):
    if not isinstance(mr, Multires):
        raise TypeError(f"{who}: expected a vpffd.Multires, got {type(mr).__name__}")


class MultiresDeformer:
    """FFD of a decomposition's base with the fine mesh rebuilt per vertex.

    Per frame: S'(t_i) = D(S(t_i)), S'_u = J_D S_u, S'_v = J_D S_v (analytic Jacobian
    at each foot point), then p' = S' + d N_S' and the approximate normal of eqs. 6-7.
    On the CPU, for lattices of one degree on all axes, the foot points are sorted by
    lattice cell once here and a frame runs one cell at a time: the cell's polynomial
    is formed once per run of foot points, D and its gradient follow by nested Horner
    four points at a time, with no per-point basis (same frame as the per-point
    evaluation, used for mixed degrees, to a few units in the last place; the same bits
    for any thread count). That keeps the foot points' embedding and the frame data
    once more in cell order (``_ffd.held_bytes_per_vertex``: 204 bytes per vertex).

    Parameters
    ----------
    multires : Multires
    lattice : Lattice
        its box must contain the base mesh (``outside``) — a lattice around the
        fine mesh does, since fairing moves vertices inwards. Periodic axes work as
        in ``Deformer``, on every backend: foot points are wrapped into the box and
        the seam's translation ("shift") or mirror ("twist") applies to the map and
        its Jacobian there.
    backend : {"auto", "openmp", "serial", "vulkan"}
        "vulkan": every part of a frame runs on the device: the volume correction
        (``Deformer(..., backend="vulkan")`` of the base or the fine mesh, see
        ``deform``'s ``volume``), then one compute dispatch that rebuilds the fine
        vertices and their approximate normals from the corrected control points
        (float32 positions relative to the lattice centre, basis values and
        derivatives evaluated in float64 or float-float). Against the CPU frame of
        the same control points the derived worst case (tests/python/gpu_bounds.py,
        multires_bounds) is a few 1e-6 of the box diagonal for positions and below
        0.01 degree for the normals of a moderate edit; lavapipe gives 5e-8 of the
        diagonal and 2e-5 degree. A frame is one queue submission: the Deformer's
        frame, then the corrected control points summed on the device from its
        buffers (no host round trip) and the reconstruction dispatch. The deformed
        base (``base_vertices``) is the base Deformer's device FFD (with
        ``volume="fine"`` run in the same submission on the corrected control
        points). A build or machine without Vulkan raises BackendUnavailableError.
        "auto" follows ``Deformer``'s rule on the fine mesh's size: a hardware GPU
        for meshes of ``vpffd.backends.AUTO_GPU_MIN_VERTICES`` vertices or more, or the
        device that ``device`` / VPFFD_VULKAN_DEVICE names; otherwise the CPU
        (OpenMP where built with it and there is more than one core). When that
        device cannot be opened it warns and stays on the CPU.
    outside : {"error", "extrapolate"}
        for base vertices outside the box (as ``Deformer``). Foot points that stray
        outside always follow the boundary polynomial pieces (the rest lattice maps
        them onto themselves).
    threads : int, optional
        OpenMP threads (default: all); results do not depend on it.
    device : int or str, optional
        "vulkan": the device (index or part of its name), as ``Deformer``.
    gpu_precision : {"auto", "float64", "float-float"}, optional
        "vulkan": how the device sums, as ``Deformer``.
    """

    def __init__(self, multires, lattice, backend: str = "auto", outside: str = "error", threads=None,
                 device=None, gpu_precision=None):
        _check_multires(multires, "MultiresDeformer")
        if not isinstance(lattice, Lattice):
            raise TypeError(f"MultiresDeformer: expected a vpffd.Lattice, got {type(lattice).__name__}")
        if not isinstance(backend, str):
            raise TypeError(f"backend: expected a string, got {type(backend).__name__}")
        precision = _requested_precision(gpu_precision)
        resolved, threads_core, selector = _resolve_backend(backend, threads, device, multires.n_vertices)
        self._vk = None
        if resolved == "vulkan":
            try:
                self._vk = _core.VulkanMultires(multires._m, lattice._spec, selector, precision)
            except (BackendUnavailableError, _core.DeviceError) as e:
                if backend != "auto":
                    raise
                warnings.warn(f"MultiresDeformer: backend 'auto' could not use Vulkan ({e}); using the CPU",
                              stacklevel=2)
                resolved, threads_core, selector = _resolve_backend(
                    "openmp" if _core.has_openmp() else "serial", threads)
        self.backend = resolved
        self._threads = threads_core
        self.multires = multires
        self.lattice = lattice
        gpu = {"device": selector, "gpu_precision": precision} if self._vk is not None else {}
        dthreads = None if self._threads == 0 else self._threads
        # The volume corrections are the Deformer's own (no second implementation),
        # on the same backend and device.
        self._deformer_args = dict(backend=self.backend, outside=outside, threads=dthreads, **gpu)
        self._base = Deformer(multires.base, lattice, **self._deformer_args)
        self._fine = None
        self._fine_lock = threading.Lock()
        self._spares = Spares()
        self._ffd = _core.MultiresFFD(multires._m, lattice._spec, self._threads) if self._vk is None else None
        self._cpu_ffd = None  # "vulkan": foot_frames' CPU map

    @property
    def device(self):
        """The Vulkan device dict (see ``vulkan_devices()``), or None on the CPU."""
        return self._vk.device if self._vk is not None else None

    @property
    def gpu_precision(self):
        """How the device sums ("float64" or "float-float"), or None on the CPU."""
        return self._vk.precision if self._vk is not None else None

    def last_timings(self) -> dict:
        """The last frame ("vulkan" only): ``gpu_total_ms``, the device time after the
        Deformer's frame (the sum of the corrected control points, [the base's FFD,]
        the reconstruction dispatch and the copies, when the queue has timestamps), and
        ``host_total_ms``, the whole frame (correction included). The correction's own
        device timings are its Deformer's (``_base`` or the fine one)."""
        if self._vk is None:
            raise InvalidInputError("last_timings: only the 'vulkan' backend records frame timings")
        return self._vk.last_timings()

    @property
    def bytes_per_vertex(self) -> int:
        """Bytes a frame reads per vertex. CPU (float64): foot-point embedding (36), S_u,
        S_v, d and the six coefficients (104): 140. Vulkan (float32): spans (12),
        local parameters, S_u, S_v, d and the coefficients (64): 76."""
        if self._vk is not None:
            return _core.VulkanMultires.frame_bytes_per_vertex
        return _core.MultiresFFD.frame_bytes_per_vertex

    def foot_frames(self, control_points=None) -> tuple:
        """The deformed base at the foot points for control points P (default the
        lattice's): S'(t_i) = D(S(t_i)) (V, 3) world units and the unit base normals
        N_S' = unit(J_D S_u x J_D S_v) (V, 3), on the CPU (the seams of a periodic
        lattice included). A rebuilt vertex is S' + d_i N_S'; a plain FFD of the fine
        mesh with the same P moves it elsewhere (``vpffd.detail_change``)."""
        P = np.ascontiguousarray(self.lattice._control(control_points).reshape(-1, 3))
        ffd = self._ffd
        if ffd is None:  # "vulkan": the CPU map, built on first use
            with self._fine_lock:
                if self._cpu_ffd is None:
                    self._cpu_ffd = _core.MultiresFFD(self.multires._m, self.lattice._spec, self._threads)
                ffd = self._cpu_ffd
        S, J = ffd.foot_values_jacobians(P, self._threads)
        J = np.asarray(J).reshape(-1, 3, 3)
        m = self.multires._m
        su = np.einsum("irc,ic->ir", J, m.tangents_u)
        sv = np.einsum("irc,ic->ir", J, m.tangents_v)
        n = np.cross(su, sv)
        length = np.linalg.norm(n, axis=1, keepdims=True)
        return np.asarray(S), np.divide(n, length, out=np.zeros_like(n), where=length > 0)

    def _fine_deformer(self) -> Deformer:
        with self._fine_lock:  # frames on several threads build it once
            if self._fine is None:
                self._fine = Deformer(self.multires.mesh, self.lattice, **self._deformer_args)
            return self._fine

    def _base_ffd(self, Pc) -> np.ndarray:
        """The deformed base mesh for control points Pc (N, 3), on the CPU."""
        return self._base.ffd(Pc)

    def deform(self, control_points=None, preserve_volume: bool = True, axes: str = "xyz", volume: str = "base",
               normals: str = "approximate", weights=None, fixed=None, rounds: int = 1, out=None,
               out_normals=None, constraints=None) -> MultiresResult:
        """One frame.

        Parameters
        ----------
        control_points : (nu, nv, nw, 3) or (N, 3), optional
            default ``lattice.control_points``; not modified.
        preserve_volume : bool
            run the exact volume correction of ``vpffd.Deformer`` (needs a closed mesh).
        axes, weights, fixed, rounds
            as ``Deformer.deform``.
        volume : {"base", "fine"}
            "base": the correction runs on the base mesh S, whose volume is then
            exact; the fine mesh's is approximate (``r.volume_error``).
            "fine": the correction runs on the FFD of the fine mesh's own vertices;
            those control points drive S'. The rebuilt fine mesh is not the FFD of
            its vertices (the displacement follows the deformed base normal), so its
            volume is approximate too; ``r.volume_error`` says by how much.
        normals : {"approximate", "exact"}
            eqs. 6-7 per vertex, or the area-weighted normals of the deformed fine
            mesh (on "vulkan" too these are computed on the CPU from the device's
            vertices: they need the neighbours, which the per-vertex dispatch has not,
            and the Vulkan Deformer's normals are those of the FFD of the fine mesh,
            not of the rebuilt one).
        out, out_normals : (V, 3) float64 arrays, optional
            the rebuilt vertices and their normals are written into these
            (C-contiguous, writable, no memory shared with the inputs; the same bits
            as without), and the result's ``vertices`` / ``normals`` are these arrays.
        constraints : list of (source, target), optional
            point constraints of ``Deformer.deform`` (a rest-space point, or a vertex
            index of the mesh the correction runs on: the base's for
            ``volume="base"``), solved with the volume correction (or alone with
            ``preserve_volume=False``): the lattice map takes each source to its
            target (``r.constraint_error``). The rebuilt fine surface follows its
            base, so a fine vertex at a source lands near the target, off it by how
            its detail turns. On "vulkan" the correction is a Deformer frame of its
            own and the reconstruction a second submission.
        """
        if not isinstance(preserve_volume, (bool, np.bool_)):
            raise TypeError(f"preserve_volume: expected a bool, got {type(preserve_volume).__name__}")
        if volume not in _VOLUME_MODES:
            raise InvalidInputError(f"volume: expected 'base' or 'fine', got {volume!r}")
        _check_normals(normals)
        P = self.lattice._control(control_points)
        nv = self.multires.n_vertices
        inputs = [("control_points", P), ("control_points", control_points), ("weights", weights), ("fixed", fixed)]
        out = _arrays.out_array(out, nv, "MultiresDeformer.deform: out", inputs)
        out_normals = _arrays.out_array(out_normals, nv, "MultiresDeformer.deform: out_normals",
                                        inputs + [("out", out)])
        # The kernel writes the approximate normals; "exact" ones are made afterwards (_result).
        # Without out arrays, those of an earlier frame that nobody holds are reused (_spare.py).
        kernel_normals = out_normals if normals == "approximate" else None
        given = out, out_normals
        if out is None:
            out = self._spares.take("vertices", (nv, 3))
        if kernel_normals is None and out_normals is None:
            kernel_normals = self._spares.take("normals", (nv, 3))
        if preserve_volume and not self.multires.mesh.is_closed:
            raise InvalidInputError(
                "MultiresDeformer.deform: the mesh does not bound a volume, so it cannot be preserved "
                f"(pass preserve_volume=False):\n{self.multires.mesh.check()}")
        cerr = float("nan")
        if constraints is not None and len(constraints) > 0:
            # The constraints go through the Deformer's own solve (with the volume
            # correction when asked); its control points then drive the frame.
            d = self._base if volume == "base" or not preserve_volume else self._fine_deformer()
            rc = d.deform(P, preserve_volume=bool(preserve_volume), axes=axes, weights=weights, fixed=fixed,
                          rounds=rounds, constraints=constraints)
            P, cerr = np.ascontiguousarray(rc.control_points.reshape(-1, 3)), rc.constraint_error
            preserve_volume = False  # those control points carry the correction already
        if self._vk is not None:
            r = self._deform_vulkan(P, preserve_volume, axes, volume, normals, weights, fixed, rounds, out,
                                    kernel_normals, out_normals, cerr)
            return self._keep_spares(r, given, normals)
        if preserve_volume:
            d = self._base if volume == "base" else self._fine_deformer()
            r = d.deform(P, preserve_volume=True, axes=axes, weights=weights, fixed=fixed, rounds=rounds)
            Pc = np.ascontiguousarray(r.control_points.reshape(-1, 3))
            B = r.vertices if volume == "base" else self._base_ffd(Pc)
        else:
            Pc = P
            B = self._base_ffd(Pc)
        X, N = self._ffd.deform(Pc, self._threads, out, kernel_normals)
        r = _result(self.multires, X, N, B, normals, Pc.reshape(*self.lattice.shape, 3), volume, self.backend,
                    out_normals, cerr)
        return self._keep_spares(r, given, normals)

    def _keep_spares(self, r, given, normals):
        """The frame's own output arrays, for a later frame once nobody holds them."""
        if given[0] is None:
            self._spares.keep("vertices", r.vertices)
        if given[1] is None and normals == "approximate":
            self._spares.keep("normals", r.normals)
        return r

    def _deform_vulkan(self, P, preserve_volume, axes, volume, normals, weights, fixed, rounds, out=None,
                       kernel_normals=None, out_normals=None, constraint_error=float("nan")):
        """One submission: the base's (or, volume="fine", the fine mesh's) Vulkan Deformer
        frame, the reconstruction from its corrected control points and, for "fine",
        the base's FFD of them."""
        base = None
        if preserve_volume:
            d = self._base if volume == "base" else self._fine_deformer()
            opts = _correction_options(d, P, axes, weights, fixed, rounds, self._threads)
            if volume == "fine":
                base = self._base._vk
        else:
            d = self._base
            opts = _core.CorrectionOptions(preserve_volume=False, threads=self._threads)
        X, N, B, r = self._vk.deform_after(d._vk, P, opts, base, out, kernel_normals)
        Pc = r["control_points"]
        return _result(self.multires, X, N, B, normals, Pc.reshape(*self.lattice.shape, 3), volume, self.backend,
                       out_normals, constraint_error)

