"""Displaced subdivision surfaces (Marinov, Botsch and Kobbelt, §5): a detailed
triangle mesh as the limit surface of a coarse control mesh (Loop or Catmull-Clark,
evaluated by OpenSubdiv) plus a normal displacement per vertex at its exact foot
point. Editing moves control points; a frame is one pass over the fine vertices
with precomputed limit stencils and the approximate normals of eqs. 6-7.

>>> import vpffd
>>> sm = vpffd.SubdivisionMultires(vpffd.shapes.bumpy_sphere(3), control_vertices=200)  # doctest: +SKIP
>>> r = sm.deform(sm.control_points * 1.1)  # doctest: +SKIP

Needs the compiled part vpffd::subdiv (OpenSubdiv 3.5, Debian ``libosd-dev``, and
OpenMesh); without it ``SubdivisionMultires`` raises BackendUnavailableError.
"""
from __future__ import annotations

import logging

import numpy as np
import scipy.sparse

from . import _arrays, _core
from ._stages import stage_reporter
from .backends import _requested_precision, _resolve_backend
from .mesh import Mesh
from .multires import MultiresResult, _check_normals, _read_only, _relative, _threads_arg, _volume

_log = logging.getLogger(__name__)
InvalidInputError = _core.InvalidInputError
BackendUnavailableError = _core.BackendUnavailableError

_SCHEMES = ("loop", "catmark")


def available() -> bool:
    """True when this build has the subdivision part (OpenSubdiv)."""
    return bool(getattr(_core, "has_opensubdiv", False))


def _require(where: str):
    if not available():
        raise BackendUnavailableError(
            f"{where}: this build of vpffd has no subdivision surfaces (OpenSubdiv was not found when it was built): "
            "install libosd-dev (Debian/Ubuntu: apt-get install libosd-dev, or scripts/setup.sh) and rebuild "
            "(scripts/setup.sh, or pip install -e . with -DVPFFD_WITH_OPENSUBDIV=ON)")


def _control_mesh(control_mesh, scheme):
    """(points (M, 3), face sizes, concatenated face vertices) of a Mesh or a (V, F)
    pair whose F is (n, 3) triangles or, for Catmull-Clark, (n, 4) quads."""
    if isinstance(control_mesh, Mesh):
        V, F = control_mesh.vertices, control_mesh.faces
    elif isinstance(control_mesh, tuple) and len(control_mesh) == 2:
        V = _arrays.points(control_mesh[0], "control_mesh vertices")
        F = np.asarray(control_mesh[1])
        if F.ndim != 2 or F.shape[1] not in (3, 4) or F.shape[0] == 0:
            raise InvalidInputError(f"control_mesh faces: expected an (n, 3) or (n, 4) array, got shape {F.shape}")
        if not np.issubdtype(F.dtype, np.integer):
            raise InvalidInputError(f"control_mesh faces: expected integers, got {F.dtype}")
        if F.min() < 0 or F.max() >= len(V):
            raise InvalidInputError(f"control_mesh faces: indices must be in [0, {len(V)}), "
                                    f"got {int(F.min())}..{int(F.max())}")
    else:
        raise TypeError(f"control_mesh: expected a vpffd.Mesh or a (vertices, faces) pair, "
                        f"got {type(control_mesh).__name__}")
    if scheme == "loop" and F.shape[1] != 3:
        raise InvalidInputError(f"SubdivisionMultires: Loop subdivision needs triangles, but the control mesh has "
                                f"{F.shape[1]}-sided faces (use scheme='catmark' for quads)")
    F = np.ascontiguousarray(F, dtype=np.int32)
    return np.ascontiguousarray(V, dtype=np.float64), [int(F.shape[1])] * len(F), F.ravel().tolist()


def _volume_gradient(B, F) -> np.ndarray:
    """d vol / d B (V, 3) of the closed mesh (B, F): vol = (1/6) sum_f p_i . (p_j x p_k),
    so vertex i of a face gets (1/6) p_j x p_k."""
    Pi, Pj, Pk = B[F[:, 0]], B[F[:, 1]], B[F[:, 2]]
    G = np.zeros_like(B)
    for idx, g in ((F[:, 0], np.cross(Pj, Pk)), (F[:, 1], np.cross(Pk, Pi)), (F[:, 2], np.cross(Pi, Pj))):
        for a in range(3):
            G[:, a] += np.bincount(idx, weights=g[:, a], minlength=len(B))
    return G / 6.0


def preserve_base_volume(Phi, F, C, target, axes="xyz", weights=None, constraints=None):
    """Hahmann et al.'s volume correction with the control points as the basis: the base
    points B = Phi C (V, 3), joined by the fine faces F, get the enclosed volume
    ``target``. One step per axis of ``axes`` (in that order); each moves the control
    points along that axis only, where the volume is linear in them, by the weighted
    least-squares offsets delta_j = a w_j alpha_j / sum_k w_k alpha_k^2 (eq. 24 with
    the paper's weights) with alpha = Phi^T d vol / d B_axis and a = (target -
    vol(Phi C)) / len(axes) fixed before the first step: after the last step the
    volume is ``target`` to rounding. ``weights`` (M,) >= 0 (None: all 1; 0: the
    point does not move). ``constraints``: (indices (K,), targets (K, 3)): base points
    (Phi C)_i that must land on their targets; each axis step then solves the paper's
    small system for the multipliers of the volume and the K constraints along that
    axis (delta = W A^T lambda, (A W A^T) lambda = b, A = [alpha; Phi_K]), so the
    volume and the targets hold together, exactly. Returns the corrected (M, 3)
    control points (a new array). Raises SolverError when an axis's step cannot
    change the volume (every point that may move has alpha = 0 there) or the
    constraints and the volume are dependent along an axis."""
    C = np.array(C, dtype=np.float64)
    w = np.ones(len(C)) if weights is None else np.asarray(weights, dtype=np.float64)
    lo, hi = _arrays.bounds(Phi @ C)
    centre = 0.5 * (lo + hi)  # volumes about the box centre: less cancellation
    share = (target - float(_core.signed_volume(Phi @ C, F, centre, False))) / len(axes)
    rows = None
    if constraints is not None:
        idx, T = constraints
        rows = Phi[idx].toarray() if hasattr(Phi, "toarray") else np.asarray(Phi[idx])
    for name in axes:
        axis = "xyz".index(name)
        alpha = Phi.T @ _volume_gradient(Phi @ C - centre, F)[:, axis]
        if rows is None:
            norm2 = float((w * alpha) @ alpha)
            if not norm2 > 0:
                raise _core.SolverError(f"preserve_volume: the volume does not depend on the {'xyz'[axis]} "
                                        f"coordinates of the control points that may move")
            C[:, axis] += share / norm2 * (w * alpha)
            continue
        A = np.vstack([alpha, rows])
        b = np.concatenate([[share], T[:, axis] - rows @ C[:, axis]])
        G = (A * w) @ A.T
        # Relative to its diagonal, a Gram matrix this close to singular has dependent
        # rows: a constraint the volume or another constraint already decides.
        d = np.sqrt(np.maximum(np.diag(G), np.finfo(float).tiny))
        if not np.linalg.cond(G / np.outer(d, d)) < 1e12:
            raise _core.SolverError(f"preserve_volume: along {name}, the volume and the {len(rows)} point "
                                    f"constraints are dependent (a constrained point's control points cannot "
                                    f"move, or two constraints pin the same points)")
        C[:, axis] += w * (A.T @ np.linalg.solve(G, b))
    return C


def _correction_weights(M, axes, weights, fixed, who):
    """Checked (axes, weights (M,) or None) of a volume correction: ``axes`` distinct
    letters of "xyz"; ``weights`` M finite values >= 0; ``fixed`` a boolean mask (M,)
    or indices of control points that must not move (their weight becomes 0)."""
    if not isinstance(axes, str) or not axes or any(a not in "xyz" for a in axes) or len(set(axes)) != len(axes):
        raise InvalidInputError(f"{who}: axes must be distinct letters of 'xyz', such as 'xyz' or 'z', got {axes!r}")
    w = None
    if weights is not None:
        w = np.array(weights, dtype=np.float64)
        if w.shape != (M,) or not np.isfinite(w).all() or (w < 0).any():
            raise InvalidInputError(f"{who}: weights must be {M} finite values >= 0 (one per control point), "
                                    f"got shape {w.shape}")
    if fixed is not None:
        f = np.asarray(fixed)
        if f.dtype == bool:
            if f.shape != (M,):
                raise InvalidInputError(f"{who}: a fixed mask must have {M} entries, got shape {f.shape}")
            idx = np.flatnonzero(f)
        else:
            if f.ndim != 1 or not np.issubdtype(f.dtype, np.integer) or (f.size and (f.min() < 0 or f.max() >= M)):
                raise InvalidInputError(f"{who}: fixed must be a boolean mask of {M} entries or indices in 0..{M - 1}")
            idx = f
        w = np.ones(M) if w is None else w
        w[idx] = 0.0
    if w is not None and not (w > 0).any():
        raise _core.SolverError(f"{who}: every control point is fixed (or has weight 0): nothing can move")
    return axes, w


class SubdivisionMultires:
    """A triangle mesh as a displaced subdivision surface (Marinov, Botsch and Kobbelt, §5).

    Each fine vertex is p_i = S(t_i) + d_i N_S(t_i) with S the limit surface of the
    control mesh and t_i = (patch, u, v) an exact foot point (p_i - S(t_i) parallel
    to N_S; tangential residual at most 1e-9 of the bounding-box diagonal). The
    control points are fitted (§4.1): a few rounds of least squares
    min sum |S(t_i) - p_i|^2 + fairness |L C|^2 (L: the control mesh's uniform
    Laplacian) alternating with foot-point updates. S, S_u, S_v at every t_i are
    stored as limit stencils (weights over the control points), so a frame
    (``deform``) reads no connectivity.

    Parameters
    ----------
    mesh : Mesh or (vertices, faces)
        the fine triangle mesh: manifold, consistently oriented (boundaries allowed).
    scheme : {"loop", "catmark"}
        Loop needs a triangle control mesh; Catmull-Clark takes triangles (each the
        union of three quad patches) and quads.
    control_mesh : Mesh or (vertices, faces), optional
        the initial control mesh ((n, 3) triangles, or (n, 4) quads for "catmark");
        its points are the fit's start. Default: decimation of ``mesh`` to about
        ``control_vertices`` vertices (OpenMesh, quadric error, no normal flips).
    control_vertices : int, optional
        size of the decimated control mesh (default: 1 % of the fine vertices, at
        least 64, at most all).
    fairness : float >= 0
        relative weight of the fairness term (default 1e-3).
    iterations : int >= 0
        fitting rounds (default 2); 0 keeps the control points given.
    approx_level : int in 1..10
        OpenSubdiv's approximation level near extraordinary vertices (default 6).
    max_unresolved : int >= 0
        vertices allowed without an exact foot point (default 0: more raise
        InvalidInputError with their count and the first ones). Accepted ones keep
        their best point; ``residuals`` shows them and ``unresolved`` lists them.
    progress : callable, optional
        called as ``progress(done, total)`` after each stage (the decimated control
        mesh, the first foot points, each fit round), from the calling thread; each
        stage is also logged at INFO level (logger ``vpffd``). An exception it raises
        stops the decomposition and propagates.
    threads : int, optional

    Attributes
    ----------
    mesh : Mesh
    control_mesh : Mesh or None
        the fitted control mesh (None for a quad control mesh: see
        ``control_faces``).
    control_points : (M, 3) float64
    control_faces : (n, 3) or (n, 4) int32
    limit_points : (V, 3) float64
        S(t_i), the foot points on the limit surface.
    displacements : (V,) float64
        d_i, world units.
    residuals : (V,) float64
        tangential residual of each foot point, world units.
    unresolved : (k,) int32
        vertices whose residual exceeds 1e-9 of the diagonal.
    rms_initial, rms_final : float
        RMS of |p_i - S(t_i)| on the initial control mesh and after the fit.
    seconds : float
        decomposition wall time.
    bytes_per_vertex : float
        bytes a frame reads per fine vertex (stencils, d, coefficients).
    """

    def __init__(self, mesh, scheme: str = "loop", control_mesh=None, control_vertices=None, fairness=1e-3,
                 iterations=2, approx_level=6, max_unresolved=0, threads=None, progress=None):
        _require("SubdivisionMultires")
        if scheme not in _SCHEMES:
            raise InvalidInputError(f"SubdivisionMultires: scheme must be 'loop' or 'catmark', got {scheme!r}")
        self.mesh = Mesh.from_any(mesh)
        fairness = _arrays.positive(fairness, "fairness", "SubdivisionMultires", allow_zero=True)
        for name, value in (("iterations", iterations), ("approx_level", approx_level),
                            ("max_unresolved", max_unresolved)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise InvalidInputError(f"SubdivisionMultires: {name} must be an integer, got {value!r}")
        threads = _threads_arg(threads)
        stage = stage_reporter("SubdivisionMultires", "rms |p - S|", progress, _log)

        V, F = self.mesh.vertices, self.mesh.faces
        _log.info("SubdivisionMultires: decomposing %d vertices (%s, %s control mesh, %d fit rounds)", len(V),
                  scheme, "given" if control_mesh is not None else "decimated", int(iterations))
        if control_mesh is not None:
            if control_vertices is not None:
                raise InvalidInputError("SubdivisionMultires: give control_mesh or control_vertices, not both")
            CV, sizes, verts = _control_mesh(control_mesh, scheme)
            self._m = _core.subdivision_decompose(V, F, CV, sizes, verts, scheme, fairness, int(iterations),
                                                  int(approx_level), int(max_unresolved), threads, stage)
        else:
            if control_vertices is None:
                control_vertices = min(len(V), max(64, len(V) // 100))
            if isinstance(control_vertices, bool) or not isinstance(control_vertices, (int, np.integer)):
                raise InvalidInputError(f"SubdivisionMultires: control_vertices must be an integer, "
                                        f"got {control_vertices!r}")
            self._m = _core.subdivision_decompose_decimated(V, F, int(control_vertices), scheme, fairness,
                                                            int(iterations), int(approx_level),
                                                            int(max_unresolved), threads, stage)
        m = self._m
        self.scheme = scheme
        self.control_points = _read_only(m.control_points)
        sizes = np.asarray(m.control_face_sizes)
        self.control_faces = _read_only(np.asarray(m.control_faces, dtype=np.int32).reshape(len(sizes), -1))
        self.control_mesh = Mesh(self.control_points, self.control_faces) if self.control_faces.shape[1] == 3 else None
        self.displacements = _read_only(m.displacements)
        self.residuals = _read_only(m.residuals)
        self.unresolved = _read_only(m.unresolved)
        self.rest_normals = _read_only(m.rest_normals)
        self.rms_initial, self.rms_final = float(m.rms_initial), float(m.rms_final)
        self.rms_rounds = tuple(m.rms_rounds)
        self.seconds = float(m.seconds)
        _log.info("SubdivisionMultires: %d control points; rms |p - S| %.4g -> %.4g; %d foot points unresolved; "
                  "%.2f s", len(self.control_points), self.rms_initial, self.rms_final, len(self.unresolved),
                  self.seconds)
        self.bytes_per_vertex = float(m.frame_bytes_per_vertex)
        X, _, B = m.deform(self.control_points, threads)
        self.limit_points = _read_only(B)
        closed = self.mesh.is_closed
        # Reference volumes of every frame's report (NaN when open); the "base" is the
        # limit points joined by the fine faces.
        self._rest_volumes = (_volume(V, F, closed), _volume(B, F, closed), closed)

    @property
    def n_vertices(self) -> int:
        return self.mesh.n_vertices

    @property
    def n_control(self) -> int:
        return len(self.control_points)

    def stencils(self) -> dict:
        """Copies of the limit stencils: CSR rows per fine vertex, ``indptr`` (V + 1,),
        ``indices`` (nnz,) control points, weights ``w`` (position), ``wu``, ``wv``
        (derivatives in the patch's (u, v))."""
        indptr, indices, w, wu, wv = self._m.stencils
        return {"indptr": indptr, "indices": indices, "w": w, "wu": wu, "wv": wv}

    def frame_data(self) -> dict:
        """Copies of the per-vertex parameters: ``patches`` (V,), ``uv`` (V, 2),
        ``displacements`` (V,), ``normal_coefficients`` (V, 6)."""
        m = self._m
        return {"patches": m.patches, "uv": m.uv, "displacements": m.displacements,
                "normal_coefficients": m.normal_coefficients}

    def _control_points(self, C) -> np.ndarray:
        C = np.asarray(C)
        if C.shape != (self.n_control, 3):
            raise InvalidInputError(f"SubdivisionMultires.deform: control_points must have shape "
                                    f"({self.n_control}, 3), got {C.shape}")
        return _arrays.points(C, "control_points", rows=self.n_control)

    def deform(self, control_points, normals: str = "approximate", preserve_volume: bool = False,
               threads=None, backend: str = "auto", device=None, gpu_precision=None, axes: str = "xyz",
               weights=None, fixed=None, constraints=None) -> MultiresResult:
        """One frame from new control points (M, 3) (not modified).

        Returns a ``MultiresResult``: ``vertices`` p' = S'(t_i) + d_i N_S',
        ``normals`` (approximate, eqs. 6-7, or "exact": area-weighted normals of the
        rebuilt mesh), ``base_vertices`` S'(t_i), ``control_points`` (M, 3): those
        given, or corrected with ``preserve_volume``.

        preserve_volume : bool
            correct the control points first (``preserve_base_volume``, Hahmann et al.'s
            closed form with the control points as the basis) so that the base points
            S'(t_i), joined by the fine faces, keep their rest volume exactly
            (``base_volume_error`` ~1e-15); the fine mesh's volume is reported
            (``volume_error``), close but not exact. Needs a closed mesh. The
            correction runs in numpy (a pass over the stencils and faces per axis).
        axes : str
            with ``preserve_volume``: the axes the control points move along, in
            order (default "xyz"; "z" keeps x and y of every control point).
        weights : (M,) array of float >= 0, optional
            with ``preserve_volume``: how freely each control point moves (the
            paper's weights: offsets proportional to them; 0 holds a point still).
        fixed : (M,) bool mask or indices, optional
            with ``preserve_volume``: control points that must not move.
        constraints : list of (vertex_index, (x, y, z)), optional
            with ``preserve_volume``: fine vertices whose base point S'(t_i) must land
            on the target (exactly, together with the volume; the fine vertex itself
            lands d_i N_S' off it). Along an axis not in ``axes`` the target must
            already hold.
        backend : {"auto", "cpu", "openmp", "serial", "vulkan"}
            "cpu": "openmp" where this build has it, else "serial". "vulkan": the frame (stencil sums and per-vertex rebuild) is one compute
            dispatch on a Vulkan device (``_core.VulkanSubdivFrame``): the stencils, d
            and the coefficients are uploaded on the first such frame and kept; a frame
            uploads the control points (float32, 12 bytes each) and reads back the
            vertices, normals and limit points (float32). Positions agree with the CPU
            to a few float32 roundings of the control points' size (see
            tests/python/test_subdivision_vulkan.py). "auto" is the CPU unless a device
            is named (``device`` or VPFFD_VULKAN_DEVICE): for the sizes this class
            decomposes the CPU frame is already a few ms.
        device : int or str, optional
            "vulkan": the device (index or part of its name), as ``Deformer``.
        gpu_precision : {"auto", "float64", "float-float"}, optional
            "vulkan": how the device forms the stencil sums, as ``Deformer``.
        """
        _check_normals(normals)
        C = self._control_points(control_points)
        volume_mode = "none"
        if preserve_volume:
            if not self.mesh.is_closed:
                raise InvalidInputError("SubdivisionMultires.deform: preserve_volume needs a closed mesh "
                                        "(this one has boundary, non-manifold or misoriented edges)")
            axes, w = _correction_weights(len(C), axes, weights, fixed, "SubdivisionMultires.deform")
            cons = self._constraints(constraints, C, axes)
            C = preserve_base_volume(self._phi(), self.mesh.faces, C, self._rest_volumes[1], axes, w, cons)
            volume_mode = "base"
        elif constraints is not None:
            raise InvalidInputError("SubdivisionMultires.deform: constraints are solved with the volume "
                                    "correction: pass preserve_volume=True")
        resolved, threads_core, selector = self._backend(backend, threads, device)
        if resolved == "vulkan":
            X, N, B = self._vulkan_frame(selector, gpu_precision).deform(C)
        else:
            X, N, B = self._m.deform(C, threads_core)
        return self._result(X, N, B, normals, C, volume_mode, resolved)

    def _constraints(self, constraints, C, axes):
        """Checked (indices (K,), targets (K, 3)) of point constraints, or None."""
        if constraints is None or len(constraints) == 0:
            return None
        who = "SubdivisionMultires.deform: constraints"
        try:
            idx = np.array([int(c[0]) for c in constraints], dtype=np.int64)
            T = np.array([np.asarray(c[1], dtype=np.float64) for c in constraints])
        except (TypeError, ValueError, IndexError) as e:
            raise InvalidInputError(f"{who}: expected a list of (vertex_index, (x, y, z)) pairs ({e})") from None
        n = self.mesh.n_vertices
        if T.shape != (len(idx), 3) or not np.isfinite(T).all():
            raise InvalidInputError(f"{who}: each target must be 3 finite numbers")
        if (idx < 0).any() or (idx >= n).any():
            raise InvalidInputError(f"{who}: vertex indices must be in 0..{n - 1}")
        if len(np.unique(idx)) != len(idx):
            raise InvalidInputError(f"{who}: a vertex is constrained twice")
        B = self._phi()[idx] @ C
        size = float(np.linalg.norm(np.ptp(self.mesh.vertices, axis=0)))
        for a in range(3):
            if "xyz"[a] not in axes:
                off = np.abs(B[:, a] - T[:, a])
                if off.max() > 1e-12 * size:
                    k = int(np.argmax(off))
                    raise InvalidInputError(f"{who}: vertex {idx[k]}'s target differs from its base point along "
                                            f"{'xyz'[a]}, which axes={axes!r} does not correct")
        return idx, T

    def _backend(self, backend, threads, device):
        """(backend, threads for the CPU core, device selector) of a frame: "auto" is
        the CPU unless a device is named (n_vertices=0 keeps _resolve_backend's size
        rule from choosing a GPU by itself)."""
        _threads_arg(threads)  # this class's message for a bad count
        if backend == "cpu":  # the CPU frame, threaded where this build has OpenMP
            backend = "openmp" if _core.has_openmp() else "serial"
        return _resolve_backend(backend, threads, device, n_vertices=0)

    def _vulkan_frame(self, selector, gpu_precision):
        """The device frame for (device, precision), made on first use and kept (its
        set-up uploads the stencils and compiles the pipeline)."""
        precision = _requested_precision(gpu_precision)
        frames = self.__dict__.setdefault("_vulkan_frames", {})
        key = (selector, precision)
        if key not in frames:
            indptr, indices, w, wu, wv = self._m.stencils
            frames[key] = _core.VulkanSubdivFrame(indptr, indices, w, wu, wv, self._m.displacements,
                                                  self._m.normal_coefficients, self.control_points, selector,
                                                  precision)
        return frames[key]

    def _phi(self):
        """Phi (V x M CSR): the position stencils, made on first use."""
        if self.__dict__.get("_phi_matrix") is None:
            st = self.stencils()
            self._phi_matrix = scipy.sparse.csr_matrix((st["w"], st["indices"], st["indptr"]),
                                                       shape=(self.n_vertices, self.n_control))
        return self._phi_matrix

    def affine_group(self, indices, control_points=None, threads=None) -> "SubdivisionAffineGroup":
        """The control points ``indices`` as a group for affine edits (§5.2.2), the
        others held at ``control_points`` (default: the fitted ones)."""
        C = self.control_points if control_points is None else self._control_points(control_points)
        idx = np.asarray(indices)
        if idx.ndim != 1 or not np.issubdtype(idx.dtype, np.integer):
            raise InvalidInputError(f"affine_group: indices must be a 1-D integer array, got "
                                    f"{idx.dtype} of shape {idx.shape}")
        g = self._m.affine_group(C, idx.astype(np.int32).tolist(), _threads_arg(threads))
        return SubdivisionAffineGroup(self, g, C)

    def _result(self, X, N, B, normals, C, volume_mode="none", backend=None) -> MultiresResult:
        F = self.mesh.faces
        if normals == "exact":
            N = _core.vertex_normals(X, F)
        rest, brest, closed = self._rest_volumes
        vol, bvol = _volume(X, F, closed), _volume(B, F, closed)
        return MultiresResult(vertices=X, normals=N, base_vertices=B, control_points=C, volume=vol,
                              rest_volume=rest, volume_error=_relative(vol, rest), base_volume=bvol,
                              base_rest_volume=brest, base_volume_error=_relative(bvol, brest), volume_mode=volume_mode,
                              normals_mode=normals,
                              backend=backend or ("openmp" if _core.has_openmp() else "serial"),
                              faces=F)

    def __repr__(self) -> str:
        r, n = self.residuals, len(self.unresolved)
        first = ", ".join(str(int(i)) for i in self.unresolved[:5])
        unresolved = f"{n} without an exact foot point (first: {first})" if n else "all foot points exact"
        rounds = " -> ".join(f"{x:.3g}" for x in (self.rms_initial,) + self.rms_rounds)
        return (f"SubdivisionMultires({self.n_vertices} vertices, {self.scheme}, {self.n_control} control points, "
                f"RMS distance {rounds}, |d| max {np.abs(self.displacements).max():.3g}, "
                f"residual max {r.max():.3g} ({r.max() / max(self._m.diagonal, 1e-300):.2g} of the diagonal), "
                f"{unresolved}, {self.bytes_per_vertex:.0f} B/vertex, decomposed in {self.seconds:.2f} s)")


class SubdivisionAffineGroup:
    """A group of control points with its basis precomputed per fine vertex
    (``SubdivisionMultires.affine_group``): ``deform(T)`` moves the group by the
    4 x 4 affine T and reads no control point. Only the fine vertices whose stencils
    reach the group (``influenced``) are rebuilt (21 numbers each); the others keep
    the frame of the held control points, computed once.

    Attributes
    ----------
    indices : (k,) int32
        the group's control points.
    influenced : (n,) int32
        the fine vertices a frame rebuilds.
    bytes_per_vertex : float
        held per fine vertex (the held frame, 72, and 168 per influenced vertex).
    """

    def __init__(self, sm: SubdivisionMultires, group, C):
        self._sm, self._g, self._C = sm, group, C
        self.indices = _read_only(group.indices)
        self.influenced = _read_only(group.rows)
        self.bytes_per_vertex = float(group.bytes_per_vertex)

    def control_points(self, transform) -> np.ndarray:
        """The control points this group's ``deform(transform)`` stands for, (M, 3)."""
        T = self._transform(transform)
        C = np.array(self._C)
        C[self.indices] = C[self.indices] @ T[:3, :3].T + T[:3, 3]
        return C

    @staticmethod
    def _transform(transform) -> np.ndarray:
        T = np.asarray(transform, dtype=np.float64)
        if T.shape != (4, 4):
            raise InvalidInputError(f"AffineGroup.deform: transform must be a 4 x 4 matrix, got shape {T.shape}")
        return T

    def deform(self, transform, normals: str = "approximate", threads=None) -> MultiresResult:
        """The frame with the group moved by ``transform`` (4 x 4 affine, last row
        0 0 0 1) and the other control points where the group was made."""
        _check_normals(normals)
        T = self._transform(transform)
        X, N, B = self._sm._m.deform_affine(self._g, T, _threads_arg(threads))
        return self._sm._result(X, N, B, normals, self.control_points(T))
