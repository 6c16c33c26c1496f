"""Triharmonic RBF space deformation of a decomposition's base (Marinov, Botsch and Kobbelt, §6,
after Botsch and Kobbelt 2005), in two modes.

General: handle points h_j (any, H >= 4) and per-frame targets h'_j; the
(H+4)^2 system is LU-factorised once, a frame is a back-substitution and one
blocked pass of the kernel over the foot points (values and Jacobians).

Regions (the paper's editing workflow, Fig. 5): a painted deformable region and K
handle regions inside it that each move by an affine 4x4 map; everything outside
the deformable region stays where it is. The deformation basis is precomputed per
free vertex, so a frame is O(V K) whatever the number of handle vertices.

>>> import numpy as np, vpffd
>>> mesh = vpffd.shapes.bumpy_sphere(3)
>>> mr = vpffd.Multires(mesh, smoothing=10)
>>> z = mesh.vertices[:, 2]
>>> rbf = vpffd.RBFDeformer(mr, deformable=z > 0, handle_regions=[np.flatnonzero(z > 0.8)])
>>> T = np.eye(4); T[2, 3] = 0.3
>>> r = rbf.deform(transforms=T)
>>> bool(np.allclose(r.vertices[z > 0.8], mesh.vertices[z > 0.8] + [0, 0, 0.3]))
True
"""
from __future__ import annotations

import numpy as np

from . import _arrays, _core
from .backends import _requested_precision, _resolve_backend
from .multires import _check_multires, _check_normals, _result, _threads_arg

InvalidInputError = _core.InvalidInputError

_MAX_FIXED_RINGS = 64


def _mean_edge(mesh) -> float:
    """Mean edge length of a triangle mesh (each interior edge counted twice)."""
    V, F = mesh.vertices, mesh.faces
    return float(np.mean([np.linalg.norm(V[F[:, a]] - V[F[:, (a + 1) % 3]], axis=1).mean() for a in range(3)]))


def _backend() -> str:
    return "openmp" if _core.has_openmp() else "serial"


def _mask(a, n: int, name: str) -> np.ndarray:
    """(n,) bool copy of a per-vertex mask (bool, or integers 0/1)."""
    arr = np.asarray(a)
    if arr.ndim != 1 or arr.shape[0] != n:
        raise InvalidInputError(f"{name}: expected a per-vertex mask of shape ({n},), got shape {arr.shape}")
    if arr.dtype == bool:
        return arr.copy()
    if not np.issubdtype(arr.dtype, np.integer) or not np.isin(arr, (0, 1)).all():
        raise InvalidInputError(f"{name}: expected booleans (or 0/1), got dtype {arr.dtype}")
    return arr.astype(bool)


def _regions(handle_regions, n: int) -> list:
    """K int64 index arrays from a list of index arrays / (n,) masks, or from one
    (n,) integer label array (0: no handle, k: region k)."""
    if isinstance(handle_regions, np.ndarray):
        lab = handle_regions
        if lab.ndim != 1 or lab.shape[0] != n:
            raise InvalidInputError(f"RBFDeformer: handle_regions as labels: expected shape ({n},), got {lab.shape}")
        if not np.issubdtype(lab.dtype, np.integer):
            raise InvalidInputError("RBFDeformer: handle_regions as one array must be integer labels "
                                    f"(0: none, k >= 1: region k), got dtype {lab.dtype}; pass a list for index sets")
        if (lab < 0).any():
            raise InvalidInputError("RBFDeformer: handle_regions labels must be >= 0")
        K = int(lab.max()) if lab.size else 0
        out = [np.flatnonzero(lab == k).astype(np.int64) for k in range(1, K + 1)]
        for k, r in enumerate(out, 1):
            if r.size == 0:
                raise InvalidInputError(f"RBFDeformer: handle region {k} is empty (no vertex has label {k})")
        return out
    if not isinstance(handle_regions, (list, tuple)):
        raise TypeError("RBFDeformer: handle_regions: expected a list of vertex index arrays or masks, or an (V,) "
                        f"integer label array, got {type(handle_regions).__name__}")
    out = []
    for k, r in enumerate(handle_regions, 1):
        a = np.asarray(r)
        if a.dtype == bool:
            if a.ndim != 1 or a.shape[0] != n:
                raise InvalidInputError(f"RBFDeformer: handle region {k}: a mask must have shape ({n},), "
                                        f"got {a.shape}")
            a = np.flatnonzero(a)
        elif a.ndim != 1 or (a.size and not np.issubdtype(a.dtype, np.integer)):
            raise InvalidInputError(f"RBFDeformer: handle region {k}: expected a 1-D array of vertex indices or a "
                                    f"boolean mask, got shape {a.shape} dtype {a.dtype}")
        out.append(np.array(a, dtype=np.int64))
    return out


def _transforms(T, K: int) -> list:
    """K (4, 4) float64 copies; one (4, 4) array is accepted when K == 1."""
    if T is None:
        raise InvalidInputError(f"RBFDeformer.deform: regions mode needs transforms ({K} of shape (4, 4))")
    arr = np.asarray(T)
    if not _arrays.is_real(arr.dtype):
        raise TypeError(f"RBFDeformer.deform: transforms: expected real numbers, got dtype {arr.dtype}")
    if arr.shape == (4, 4):
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[1:] != (4, 4) or arr.shape[0] != K:
        raise InvalidInputError(f"RBFDeformer.deform: transforms: expected {K} affine maps of shape (4, 4) "
                                f"(array ({K}, 4, 4)), got shape {np.shape(T)}")
    return [np.array(t, dtype=np.float64, order="C") for t in arr]


class RBFDeformer:
    """Triharmonic RBF space deformation of a decomposition's base (paper §6).

    r(x) = sum_j w_j |x - h_j|^3 + A x + b interpolates the constraints; the fine
    mesh is rebuilt from S' = r(S(t_i)), S'_u = J_r S_u, S'_v = J_r S_v (eq. 1 and
    the approximate normals of eqs. 6-7).

    General mode: ``RBFDeformer(mr, handles)``, frames ``deform(targets)``. The
    (H+4)^2 system is LU-factorised here; a frame is a back-substitution and one
    blocked pass over the foot points, O(V H).

    Regions mode: ``RBFDeformer(mr, deformable=mask, handle_regions=[idx, ...])``,
    frames ``deform(transforms=T)`` with one affine 4x4 map per handle region.
    Vertices outside ``deformable`` stay fixed (rest position and normal); handle
    vertices move with their map (normals by its cofactor matrix); the free ones (in
    the deformable region, in no handle) follow the RBF that takes each handle
    region's base vertices h_j to T_k h_j and the fixed base vertices within
    ``fixed_rings`` edges of the deformable region to themselves. The basis of
    that RBF is precomputed per free vertex (16 K doubles), so a frame costs
    O(V K), the same for 10 or 10,000 handle vertices, and equals the general
    mode's frame of ``handles`` (the constraint points), targets =
    ``targets(T)`` on the free vertices (to rounding). Construction is one
    O(H^3) factorisation and an O(V_free H K) evaluation.

    Parameters
    ----------
    multires : Multires
    handles : (H, 3) rest-space points, or a Mesh (its vertices); general mode
        H >= 4, distinct, not all in one plane (else InvalidInputError naming the problem).
    threads : int, optional
    deformable : (V,) bool mask, optional; regions mode
        the painted deformable region (default: every vertex, no fixed part).
    handle_regions : list of index arrays or (V,) bool masks, or a (V,) int label array
        regions mode: K >= 1 disjoint, non-empty vertex sets inside ``deformable``
        (labels: 0 none, k region k). Copied.
    fixed_rings : int, default 2
        rings of fixed vertices around the deformable region that hold r to the
        identity (0..64).
    spacing : float >= 0, optional
        least distance between two constraint points of one handle region (or of
        the fixed rings), world units: their base vertices are thinned greedily to
        it. Default: the mesh's mean edge length (a scan's crowded vertices make the
        (H+4)^2 system numerically singular otherwise: the armadillo's head as a
        handle is refused at 0 and solved at one edge length); 0 keeps every vertex.
        Handle vertices move with their map either way.

    Notes
    -----
    Bad input (InvalidInputError, naming it): masks of the wrong length, an empty
    deformable region, overlapping or empty handle regions, handle vertices outside
    the deformable region, handle regions that leave no free vertex, constraint
    points the RBF cannot interpolate; per frame, a wrong number of maps, a map
    with NaN, a last row other than (0, 0, 0, 1) or a singular 3x3 part.
    """

    def __init__(self, multires, handles=None, threads=None, *, deformable=None, handle_regions=None,
                 fixed_rings: int = 2, spacing=None):
        _check_multires(multires, "RBFDeformer")
        self.multires = multires
        self._threads = _threads_arg(threads)
        self._regions = None
        self._rbf = None
        if handle_regions is None and deformable is None:
            if handles is None:
                raise InvalidInputError("RBFDeformer: give handles (general mode) or handle_regions (regions mode)")
            if hasattr(handles, "vertices") and hasattr(handles, "faces"):
                handles = np.asarray(handles.vertices)
            H = _arrays.points(handles, "RBFDeformer: handles")
            self.handles = _read_only(H)
            self._rbf = _core.RbfMap(H)
            return
        if handles is not None:
            raise InvalidInputError("RBFDeformer: give either handles (general mode) or deformable/handle_regions "
                                    "(regions mode), not both")
        if handle_regions is None:
            raise InvalidInputError("RBFDeformer: regions mode needs handle_regions (at least one vertex set)")
        if isinstance(fixed_rings, bool) or not isinstance(fixed_rings, (int, np.integer)) \
                or not 0 <= fixed_rings <= _MAX_FIXED_RINGS:
            raise InvalidInputError(f"RBFDeformer: fixed_rings: expected an integer in 0..{_MAX_FIXED_RINGS}, "
                                    f"got {fixed_rings!r}")
        n = multires.n_vertices
        mask = np.ones(n, bool) if deformable is None else _mask(deformable, n, "RBFDeformer: deformable")
        regions = _regions(handle_regions, n)
        spacing = _mean_edge(multires.mesh) if spacing is None else \
            _arrays.positive(spacing, "spacing", "RBFDeformer", allow_zero=True)
        self._regions = _core.RbfRegions(multires._m, mask.astype(np.uint8), regions, int(fixed_rings), spacing,
                                         self._threads)
        self.handles = _read_only(self._regions.constraint_points)
        self.labels = _read_only(self._regions.labels)
        self.constraint_vertices = _read_only(self._regions.constraint_vertices)

    @property
    def mode(self) -> str:
        """"general" (handle points and targets) or "regions" (affine handle regions)."""
        return "general" if self._regions is None else "regions"

    @property
    def n_handles(self) -> int:
        """Constraint points H (regions mode: handle vertices plus the fixed rings)."""
        return self.handles.shape[0]

    @property
    def n_regions(self) -> int:
        """Handle regions K (regions mode)."""
        self._need("regions", "n_regions")
        return int(self._regions.n_regions)

    def _need(self, mode, what):
        if self.mode != mode:
            raise InvalidInputError(f"RBFDeformer.{what}: only in {mode} mode (this deformer is in {self.mode} mode)")

    def targets(self, transforms) -> np.ndarray:
        """Regions mode: the (H, 3) constraint targets of ``transforms`` (T_k h_j for
        handle points, h_j for fixed ones), i.e. the general mode's targets for
        ``handles`` that give the same frame."""
        self._need("regions", "targets")
        return self._regions.targets(_transforms(transforms, self.n_regions))

    def _solve(self, targets):
        T = _arrays.points(targets, "RBFDeformer: targets", rows=self.n_handles)
        return self._rbf.solve(T)

    def deform(self, targets=None, normals: str = "approximate", *, transforms=None, backend: str = "auto",
               device=None, gpu_precision=None):
        """One frame (MultiresResult; ``control_points`` is None).

        General mode: ``targets`` (H, 3), each handle's image (world units).
        Regions mode: ``transforms`` (K, 4, 4) (or (4, 4) for K = 1), one affine map
        per handle region, last row (0, 0, 0, 1). Neither is modified.

        backend : {"auto", "cpu", "openmp", "serial", "vulkan"}
            "cpu": "openmp" where this build has it, else "serial". "vulkan" (regions
            mode only): the frame is one compute dispatch on a Vulkan device
            (``_core.VulkanRbfFrame``): labels, rest points, the basis (16 K reals per
            free vertex), d and the coefficients are uploaded on the first such frame
            and kept; a frame uploads the K maps and reads back vertices, normals and
            base vertices (float32). Positions agree with the CPU to a few float32
            roundings of the mesh's size (see tests/python/test_rbf_regions_vulkan.py).
            "auto" is the CPU unless a device is named (``device`` or
            VPFFD_VULKAN_DEVICE).
        device : int or str, optional
            "vulkan": the device (index or part of its name), as ``Deformer``.
        gpu_precision : {"auto", "float64", "float-float"}, optional
            "vulkan": how the device forms the affine sums, as ``Deformer``.
        """
        _check_normals(normals)
        if backend == "cpu":  # the CPU frame, threaded where this build has OpenMP
            backend = _backend()
        resolved, _, selector = _resolve_backend(backend, None, device, n_vertices=0)
        if self._regions is not None:
            if targets is not None:
                raise InvalidInputError("RBFDeformer.deform: regions mode takes transforms=, not targets")
            T = _transforms(transforms, self.n_regions)
            if resolved == "vulkan":
                X, N, B = self._vulkan_frame(selector, gpu_precision).deform(T)
            else:
                X, N, B = self._regions.deform(T, self._threads)
        else:
            if transforms is not None:
                raise InvalidInputError("RBFDeformer.deform: general mode takes targets, not transforms= "
                                        "(give deformable/handle_regions for the regions mode)")
            if resolved == "vulkan" and backend == "vulkan":
                raise InvalidInputError("RBFDeformer.deform: backend 'vulkan' runs the regions mode only "
                                        "(deformable/handle_regions); the general mode is a CPU frame")
            resolved = _backend()  # "auto" with a named device: the general mode stays on the CPU
            W = self._solve(targets)
            X, N = self._rbf.deform(self.multires._m, W, self._threads)
            B = self._rbf.map(W, self.multires.base.vertices, self._threads)
        return _result(self.multires, X, N, B, normals, None, "none",
                       "vulkan" if resolved == "vulkan" else _backend())

    def _vulkan_frame(self, selector, gpu_precision):
        """The device frame for (device, precision), made on first use and kept (its
        set-up uploads the basis and compiles the pipeline)."""
        precision = _requested_precision(gpu_precision)
        frames = self.__dict__.setdefault("_vulkan_frames", {})
        key = (selector, precision)
        if key not in frames:
            frames[key] = _core.VulkanRbfFrame(self._regions, selector or "", precision)
        return frames[key]

    def map(self, points, targets) -> np.ndarray:
        """General mode: (n, 3) images of rest-space ``points`` under the map for ``targets``."""
        self._need("general", "map")
        X = _arrays.points(points, "RBFDeformer.map: points")
        return self._rbf.map(self._solve(targets), X, self._threads)

    def jacobians(self, points, targets) -> np.ndarray:
        """General mode: (n, 3, 3) Jacobians dr/dx at rest-space ``points`` (analytic)."""
        self._need("general", "jacobians")
        X = _arrays.points(points, "RBFDeformer.jacobians: points")
        return self._rbf.jacobians(self._solve(targets), X, self._threads).reshape(-1, 3, 3)


def _read_only(a) -> np.ndarray:
    a = np.array(a)
    a.setflags(write=False)
    return a
