"""Volume-preserving deformation of one mesh by one lattice: the Deformer (backend
choice in backends.py, the frame's result in result.py)."""
from __future__ import annotations

import functools
import os
import threading
import time
import warnings
import weakref

import numpy as np
import scipy.sparse as sp

from . import _arrays, _core
from . import folds as _folds
from . import local_weights as _local_weights
from .lattice import Lattice, _check_memory
from .backends import (AUTO_GPU_MIN_VERTICES, _requested_precision, _resolve_backend,  # noqa: F401
                       available_backends, vulkan_devices)
from ._rest_lock import RestLock
from ._spare import Spares
from .mesh import Mesh
from .result import DeformResult, RestVolumeSource

InvalidInputError = _core.InvalidInputError
BackendUnavailableError = _core.BackendUnavailableError

# Memory a frame needs per control point: the control points in, the offsets and
# corrected points out (on both sides of the binding), the weights, each axis step's
# rows, weighted rows, coefficients and offsets, and one coefficient buffer per thread:
# about 40 doubles. And per vertex, the Deformer's own data (bytes_per_vertex, about 160
# bytes) plus a frame's positions in processing and caller order and the result (72).
# A Deformer whose rest mesh has moved keeps 40-44 bytes more (the next move's embedding
# and cells; the order its vertex fans are in until a frame relabels them), which this
# check at construction does not count.
_FRAME_BYTES_PER_CONTROL_POINT = 320
_BYTES_PER_VERTEX = 256
# With K parts an axis step holds K coefficient rows of N doubles, and the solve copies
# them into its scaled and weighted rows: three K x N arrays of doubles.
_FRAME_BYTES_PER_CONTROL_POINT_AND_PART = 24


def _frame(method):
    """A method that reads the rest state: runs beside other frames, never during a move."""
    @functools.wraps(method)
    def held(self, *args, **kwargs):
        with self._rest_lock.shared():
            return method(self, *args, **kwargs)
    return held


def _move(method):
    """A method that moves the rest mesh: waits for the frames in flight and runs alone."""
    @functools.wraps(method)
    def held(self, *args, **kwargs):
        with self._rest_lock.exclusive():
            return method(self, *args, **kwargs)
    return held


def _part_labels(parts, n_vertices: int):
    """``parts`` as the binding takes it: None, "components", or (V,) int64 labels."""
    if parts is None:
        return None
    if isinstance(parts, str):
        if parts != "components":
            raise InvalidInputError(f"parts: expected 'components' or one integer label per vertex, got {parts!r}")
        return parts
    arr = np.asarray(parts)
    if arr.dtype == bool or not np.issubdtype(arr.dtype, np.integer):
        raise TypeError(f"parts: expected integer labels (one per vertex) or 'components', got dtype {arr.dtype}")
    if arr.shape != (n_vertices,):
        raise InvalidInputError(f"parts: expected {n_vertices} labels (one per vertex), got shape {arr.shape}")
    return np.array(arr, dtype=np.int64)


class Deformer:
    """Deforms ``mesh`` with ``lattice``, keeping its enclosed volume.

    Construction embeds the mesh once (a knot span and a local parameter per
    vertex and axis, 36 bytes per vertex); every ``deform`` call then costs one
    FFD plus, per corrected axis, one pass over the faces and two over the vertices.

    Threads: one Deformer may be shared by any number of threads on every backend.
    Frames (``ffd``, ``deform``, ``jacobians``, ``check_folds``, ...) release the GIL
    and run side by side (on "vulkan" the device runs them one at a time); a move of
    the rest mesh (``set_rest_vertices``, ``set_rest_offsets``) waits for the frames in
    flight, holds back new ones and runs alone, so every frame is that of the rest
    mesh before the move or of the one after it, bit for bit, never a mix. A move
    called from inside a frame on the same thread (a callback) raises RuntimeError.

    Parameters
    ----------
    mesh : Mesh, (vertices, faces) pair, or object with vertices/faces
    lattice : Lattice
        its box must contain the mesh (see ``outside``).
    backend : {"auto", "openmp", "serial", "vulkan"}
        "auto" takes a GPU through Vulkan when there is one and the mesh has at
        least ``AUTO_GPU_MIN_VERTICES`` (20,000) vertices, else the CPU (a named
        ``device`` is always used); ``available_backends()`` lists them.
        "vulkan" runs every frame on the device (float32 positions, float64 or
        float-float sums; worst-case bounds derived from that arithmetic: vertices
        within about 3e-5 of the lattice box diagonal of the CPU's for cubics, a
        corrected volume within about 6e-8 relative; typically seen 4e-7 and 7e-9)
        and raises BackendUnavailableError saying why when there is no suitable device.
    outside : {"error", "extrapolate"}
        vertices outside the lattice box raise (default) or follow the boundary
        polynomial pieces.
    threads : int, optional
        OpenMP threads (default: all). Results do not depend on the thread count.
    device : int or str, optional
        Vulkan device: an index or part of its name (``vulkan_devices()``); default
        the VPFFD_VULKAN_DEVICE environment variable, else the first suitable one
        (GPUs before software devices). Naming one makes "auto" use Vulkan.
    gpu_precision : {"auto", "float64", "float-float"}, optional
        How the Vulkan backend sums (weights, coefficients, volumes, offsets):
        float64, or float-float pairs (about 48 bits from float32 arithmetic, for
        devices without float64, and an option where it is slow; same tolerances).
        Default: the VPFFD_VULKAN_PRECISION environment variable, else "auto"
        (float64 where the device has it). Ignored on the CPU, which is float64.
    parts : (V,) integer labels or "components", optional
        several objects in one mesh, each keeping its own volume: a label per
        vertex (every face's vertices must share one, and each part must be
        closed), or "components" for the connected components of the faces.
        ``deform(preserve_volume=True)`` then restores every part's volume (one
        volume row per part in each axis step's solve); results carry
        ``part_volumes``. On "vulkan" at most 64 parts.

    Attributes
    ----------
    mesh : Mesh
        the rest mesh: after ``set_rest_vertices`` or ``set_rest_offsets`` a new Mesh
        with the new rest vertices and the same faces (a Mesh object held elsewhere is
        unchanged).
    """

    def __init__(self, mesh, lattice: Lattice, backend: str = "auto", outside: str = "error", threads=None,
                 device=None, gpu_precision=None, parts=None):
        if not isinstance(lattice, Lattice):
            raise TypeError(f"lattice: expected a vpffd.Lattice, got {type(lattice).__name__}")
        precision = _requested_precision(gpu_precision)
        self._rest_lock = RestLock()
        self._mesh_lock = threading.Lock()  # the moved Mesh, made when first read
        self._mesh = Mesh.from_any(mesh)
        # set_rest_offsets: the base positions it moves from (None before its first
        # move), and the offsets of the last move while `_mesh` waits to become the
        # moved mesh (the translated vertices are made only when read).
        self._base = None
        self._pending_offsets = None
        self.lattice = lattice
        labels = _part_labels(parts, self.mesh.n_vertices)
        _check_memory(lattice.n_control_points, "Deformer", _FRAME_BYTES_PER_CONTROL_POINT,
                      _BYTES_PER_VERTEX * self.mesh.n_vertices)
        self.backend, self._threads, selector = _resolve_backend(backend, threads, device, self.mesh.n_vertices)
        self._vk = None
        if self.backend == "vulkan":
            try:
                self._vk = _core.VulkanDeformer(self.mesh.vertices, self.mesh.faces, lattice._spec, outside, selector,
                                                precision, labels)
            except (BackendUnavailableError, _core.DeviceError) as e:
                if backend != "auto":
                    raise
                warnings.warn(f"Deformer: backend 'auto' could not use Vulkan ({e}); using the CPU", stacklevel=2)
                self.backend, self._threads, _ = _resolve_backend("openmp" if _core.has_openmp() else "serial",
                                                                  threads)
        # The CPU core keeps the matrices, ffd() and jacobians() for both. On "vulkan" it
        # is the device deformer's CPU twin, which follows set_rest_vertices lazily: `_d`
        # brings it up to date, `_core` (faces, sizes, labels: what a move keeps) does not.
        self._core = self._vk.cpu if self._vk is not None else _core.Deformer(
            self.mesh.vertices, self.mesh.faces, lattice._spec, outside, self._threads, labels)
        self._last_frame = None  # Vulkan: (control points, options) of the last frame kept (see on_fold)
        self._auto_weight_rest = None  # local_weights: the rest mesh's cone volumes, for weights="auto"
        # The core's options of frames without per-frame arrays, by their scalar settings:
        # building one from keywords costs about as much as the FFD of 500 vertices, and an
        # animation asks for the same few every frame. The core only reads them.
        self._plain_options = {}
        self._spares = Spares()  # output arrays of earlier frames that nobody holds (_spare.py)
        self._last_python_ms = 0.0  # the last deform call, end to end (last_timings)
        # DeformResult.rest_volume before it is summed (result.py): the current rest
        # mesh's source, and every source handed out to a result and not read yet.
        self._rest_source = RestVolumeSource(self)
        self._rest_sources_out = weakref.WeakSet()
        if labels is not None:
            _check_memory(lattice.n_control_points, f"Deformer with {self._core.n_parts} parts",
                          _FRAME_BYTES_PER_CONTROL_POINT + _FRAME_BYTES_PER_CONTROL_POINT_AND_PART * self._core.n_parts,
                          _BYTES_PER_VERTEX * self.mesh.n_vertices)

    def __del__(self):
        # Results refer to their Deformer weakly: what they have not read of the rest
        # volume is summed now, while the core is still here.
        out = getattr(self, "_rest_sources_out", None)
        if not out:
            return
        holder = self._holder
        for source in list(out):
            try:
                source.resolve(holder)
            except Exception:  # noqa: BLE001 (a finaliser must not raise; the read will say so)
                pass

    @property
    @_frame
    def mesh(self) -> Mesh:
        """The rest mesh: after ``set_rest_vertices`` or ``set_rest_offsets`` a new Mesh
        with the moved vertices and the same faces (a Mesh object held elsewhere is
        unchanged)."""
        with self._mesh_lock:
            if self._pending_offsets is not None:
                O = self._pending_offsets
                parts = self._core.vertex_parts if self._core.has_parts else None
                # The core's own sum (base + offset, one rounding): the same bits.
                X = self._base + (O[parts] if parts is not None else O[0])
                self._mesh = self._mesh._with_vertices(X)
                self._pending_offsets = None
            return self._mesh

    @property
    def _holder(self):
        """The object holding the current rest mesh and its volume: the Vulkan deformer or the CPU core."""
        return self._vk if self._vk is not None else self._core

    @property
    def _d(self):
        """The CPU core Deformer of the current rest mesh. On "vulkan" the first use after
        ``set_rest_vertices`` re-embeds it on the host (frames never need it)."""
        return self._vk.cpu if self._vk is not None else self._core

    # --- properties -----------------------------------------------------------
    @property
    @_frame
    def rest_volume(self) -> float:
        """Volume of the rest mesh (raises for an open mesh); after a move summed on first use."""
        return self._holder.rest_volume()

    @property
    def rest_vertices(self) -> np.ndarray:
        """(V, 3) float64 the current rest vertices (read-only; ``set_rest_vertices`` moves them)."""
        return self.mesh.vertices

    @property
    def n_parts(self) -> int:
        """Number of parts (1 without ``parts``: the whole mesh)."""
        return self._core.n_parts

    @property
    def part_labels(self):
        """(K,) int64 the label of each part, in the order of ``part_volumes`` (for
        ``parts="components"``: 0..K-1, components numbered by their lowest vertex);
        None without parts."""
        return np.array(self._core.part_labels, dtype=np.int64) if self._core.has_parts else None

    @property
    def vertex_parts(self):
        """(V,) int32 the part index (0..K-1) of each vertex; None without parts.
        Vertices that no face uses are in part 0."""
        return self._core.vertex_parts if self._core.has_parts else None

    @property
    @_frame
    def rest_part_volumes(self):
        """(K,) float64 the volume of each part of the rest mesh; None without parts."""
        if not self._core.has_parts:
            return None
        return self._vk.rest_part_volumes() if self._vk is not None else self._core.rest_part_volumes()

    @_move
    def set_rest_vertices(self, vertices) -> None:
        """Moves the rest mesh: the next frame deforms ``vertices`` (V, 3) (same faces)
        exactly as a Deformer built on that mesh would: new embedding, processing
        order and rest volume(s), so an object can travel through the lattice frame
        by frame. On the CPU it costs each vertex's cell, a counting sort by cell and
        the embedding (straight into the sorted order): 1.1-2.7 plain FFD frames
        (``bench/results/vm/motion_vm.md``). What only a volume-preserving frame needs
        waits for the first such frame: the vertex fans relabelled into the new order
        (once, for any number of moves before it) and the new rest volume, its target
        (``rest_volume`` and a result's ``rest_volume`` sum it when read); a plain
        frame needs neither, nor the faces renumbered. On "vulkan" only
        the vertices go to the device, which embeds them and sorts them by lattice
        cell itself, first thing in the next frame's submission (the rest volume is
        summed on the host in float64); the result equals a Vulkan Deformer built on
        the moved mesh within the backend's float32 tolerance
        (``bench/python/bench_motion.py`` measures both). ``mesh`` becomes a new
        Mesh of these vertices; the caller's array is copied, never modified. These
        vertices become the base of later ``set_rest_offsets``, the cheaper move for
        objects that only travel. On the CPU, with ``parts``, a part whose rows of X
        are its rest positions (bit for bit) keeps its embedding: when at most half of
        the vertices move, only the moved parts are embedded again, with the same
        result.

        Raises
        ------
        InvalidInputError
            wrong shape, NaN/Inf, or vertices outside the lattice box (unless built
            with ``outside="extrapolate"``): the message says how many and the first.
            The Deformer is unchanged then.
        """
        # NaN and infinities are refused by the core's embedding, which reads every
        # coordinate anyway ("vertex i has a non-finite coordinate").
        X = _arrays.points(vertices, "set_rest_vertices: vertices", rows=self._mesh.n_vertices, finite=False)
        holder = self._holder
        known = holder.rest_volume(True) if holder.rest_volume_known else None
        old = self._volume_vertices()
        if self._vk is not None:
            self._vk.set_rest_vertices(X)
        else:
            self._core.set_rest_vertices(X, self._threads)
        # Results of the old rest mesh that have not read its volume sum it from its vertices.
        self._rest_source.retire(old, known)
        self._rest_source = RestVolumeSource(self)
        self._pending_offsets = None
        self._base = None
        self._mesh = self._mesh._with_vertices(X)

    @_move
    def set_rest_offsets(self, offsets) -> None:
        """Moves the rest mesh by translations: each part's vertices (with ``parts``;
        the whole mesh's without) to their base positions plus the part's offset. The
        base is the rest mesh of construction or of the last ``set_rest_vertices``:
        offsets do not add up from one call to the next. This is the moving-object
        input of the GPU FFD paper (rest positions x + o(t): the whales' ring, a car
        over terrain; ``animate.PathOffset.offset`` gives o(t)).

        The next frame equals the one after ``set_rest_vertices(base + offsets)``, bit
        for bit, with one difference: the rest volumes, the targets of
        ``preserve_volume``, stay those of the base (a translation does not change a
        closed surface's volume; summing the moved positions again would differ by
        rounding only), so they are summed once, not after every move. An open mesh
        without parts (``allow_open``: cone volumes from the lattice centre, which a
        translation changes) sums them again, as ``set_rest_vertices`` does. On
        "vulkan" only the K offsets go to the device, which moves, embeds and sorts
        the vertices it keeps; the host tests the moved parts' bounding boxes against
        the lattice box (the same refusals as ``set_rest_vertices``, in O(K)). On the
        CPU a part whose offset is the one it already has (bit for bit) keeps its
        embedding: when at most half of the vertices move (one object among still
        ones), only the moved parts are embedded again, with the same result.

        Parameters
        ----------
        offsets : (3,) or (K, 3) float
            one translation for every part (or for the whole mesh), or one per part in
            the order of ``part_labels`` (K = ``n_parts``), in world units.

        Raises
        ------
        InvalidInputError
            wrong shape, NaN/Inf, or vertices moved outside the lattice box (unless
            built with ``outside="extrapolate"``). The Deformer is unchanged then.
        """
        K = self._core.n_parts
        try:
            arr = np.asarray(offsets)
        except ValueError:  # ragged nested sequences
            raise InvalidInputError(f"set_rest_offsets: offsets: expected shape (3,) or ({K}, 3), got a ragged "
                                    f"sequence") from None
        if not _arrays.is_real(arr.dtype):
            raise TypeError(f"set_rest_offsets: offsets: expected real numbers, got dtype {arr.dtype}")
        if arr.shape == (3,):
            arr = np.broadcast_to(arr, (K, 3))
        if arr.shape != (K, 3):
            raise InvalidInputError(f"set_rest_offsets: offsets: expected shape (3,) or ({K}, 3) (one row per part), "
                                    f"got {arr.shape}")
        O = np.array(arr, dtype=np.float64, order="C")
        keep = self._core.has_parts or self._core.is_closed
        retire = None
        if not keep:
            holder = self._holder
            retire = (self._volume_vertices(), holder.rest_volume(True) if holder.rest_volume_known else None)
        base = self._base if self._base is not None else self.mesh.vertices
        if self._vk is not None:
            self._vk.set_rest_offsets(O)
        else:
            self._core.set_rest_offsets(O, self._threads)
        if retire is not None:
            # The volume changes with the move: results of the old rest mesh keep theirs.
            self._rest_source.retire(*retire)
            self._rest_source = RestVolumeSource(self)
        # else the rest volumes stay the base's: results keep reading the current source.
        self._base = base
        self._pending_offsets = O

    def _volume_vertices(self) -> np.ndarray:
        """The vertices the current rest volume is the sum of: the base's after
        ``set_rest_offsets`` on a closed mesh or parts, else the rest vertices."""
        if self._base is not None and (self._core.has_parts or self._core.is_closed):
            return self._base
        return self.mesh.vertices

    @property
    def bytes_per_vertex(self) -> float:
        """Per-vertex data kept between frames, in bytes."""
        return self._core.bytes_per_vertex

    @property
    def n_control_points(self) -> int:
        return self._core.n_control_points

    # --- frames ---------------------------------------------------------------
    def _P(self, control_points):
        return self.lattice._control(control_points)

    @_frame
    def ffd(self, control_points=None, out=None) -> np.ndarray:
        """Plain FFD of the vertices: (V, 3). ``control_points`` default to the lattice's.
        ``out``: a (V, 3) float64 C-contiguous writable array to write the vertices
        into (and return), as ``deform``'s."""
        P = self._P(control_points)
        out = _arrays.out_array(out, self._mesh.n_vertices, "ffd: out",
                                [("control_points", P), ("control_points", control_points)])
        if out is not None:
            return self._d.ffd(P, self._threads, out)
        X = self._d.ffd(P, self._threads, self._spares.take("ffd", (self._mesh.n_vertices, 3)))
        self._spares.keep("ffd", X)
        return X

    @_frame
    def jacobians(self, control_points=None) -> np.ndarray:
        """(V, 3, 3) Jacobians dD/dx at the vertices (J[v, r, c] = dD_r/dx_c)."""
        return self._d.jacobians(self._P(control_points), self._threads).reshape(-1, 3, 3)

    @_frame
    def jacobian_determinants(self, control_points=None) -> np.ndarray:
        """(V,) det J at the vertices: the local volume ratio of the FFD (below 1
        compressed, above 1 expanded, <= 0 folded); ``np.linalg.det(jacobians(P))``
        without the (V, 3, 3) array."""
        return self._d.jacobian_determinants(self._P(control_points), self._threads)

    def basis_matrix(self) -> sp.csr_matrix:
        """(V, N) scipy CSR basis matrix B: ``ffd(P) == B @ P.reshape(-1, 3)``.
        Column c is control point ``control_points.reshape(-1, 3)[c]`` (the distinct
        ones of a periodic lattice; refused with a "shift" seam, where the map is affine)."""
        return self.lattice._linear_basis(self._extended_basis(), "Deformer.basis_matrix")

    @_frame
    def _extended_basis(self) -> sp.csr_matrix:
        """(V, N_ext) basis matrix over the extended lattice (== basis_matrix() without periodic axes)."""
        data, indices, indptr, shape = self._d.basis_matrix(self._threads)
        return sp.csr_matrix((data, indices, indptr), shape=shape)

    @_frame
    def face_matrix(self) -> sp.csr_matrix:
        """(N, F) the paper's coefficient matrix: alpha = M @ n_x, n_x the x
        components of the unnormalised face normals (Section 6.2). Periodic lattice:
        rows are the distinct control points (a tied copy's row added to its own)."""
        data, indices, indptr, shape = self._d.face_matrix(self._threads)
        M = sp.csr_matrix((data, indices, indptr), shape=shape)
        return (self.lattice._fold_matrix().T @ M).tocsr() if self.lattice.periodic else M

    @_frame
    def face_matrix_nnz(self) -> int:
        """Non-zeros of the paper's face matrix (its Table 1); builds it once."""
        return self._d.face_matrix_nnz(self._threads)

    @_frame
    def volume_coefficients(self, vertices, axis, method: str = "traversal"):
        """(alpha, volume): the N coefficients of ``axis`` ('x', 'y', 'z' or 0..2) for
        the mesh with the given current vertices (V, 3), and its volume. Moving the
        control points by delta along that axis changes the volume by alpha @ delta."""
        a = _arrays.axis(axis)
        X = _arrays.points(vertices, "volume_coefficients: vertices", rows=self._mesh.n_vertices)
        alpha, volume = self._d.volume_coefficients(X, a, method, self._threads)
        if self.lattice.periodic:  # a move of a distinct point moves its tied copies too
            alpha = self.lattice._fold_matrix().T @ alpha
        return alpha, volume

    @_frame
    def deform(self, control_points=None, preserve_volume: bool = True, axes: str = "xyz", weights=None,
               fixed=None, constraints=None, target_volume=None, method: str = "traversal",
               allow_open: bool = False, rounds: int = 1, on_fold: str = "ignore",
               normals: bool = False, allow_inversion: bool = False, out=None, out_normals=None) -> DeformResult:
        """Deforms the mesh and corrects its volume.

        Parameters
        ----------
        control_points : (nu, nv, nw, 3) or (N, 3), optional
            the user's lattice; default ``lattice.control_points``. Not modified.
        preserve_volume : bool
            correct the volume to ``target_volume`` (exactly, to rounding).
        axes : str
            axes the control points may move along, in order: "xyz" (default),
            "xy" (horizontal only), "z", ... Each takes an equal share of the gap.
        weights : (nu, nv, nw) or (N,) positive floats, or "auto", optional
            weighted least squares (Remark 2): large weights keep points still.
            "auto": derived from where the plain FFD changed the volume, so the
            correction stays where the edit was (``vpffd.local_weights``).
        fixed : (nu, nv, nw) or (N,) bool, optional
            control points that must not move.
        constraints : list of (source, target), or (sources, targets) arrays, optional
            point constraints (Problem 2): ``source`` is a vertex index or a
            rest-space point (3,), ``target`` the (3,) world position it must reach.
            Also a pair of numpy arrays: vertex indices (k,) int or rest-space points
            (k, 3), and targets (k, 3) (a 2-tuple whose second item is a 2-D numpy
            array is read so). Any number; each must move only along corrected axes.
            Not modified; ``result.constraints`` gives them back as points.
        target_volume : float or sequence of K floats, optional
            default: the rest volume. With ``parts``: one volume per part (in the
            order of ``part_labels``), default each part's rest volume. A target
            that is zero or of the other sign than the rest volume is refused
            (see ``allow_inversion``).
        allow_inversion : bool
            accept such a target: the surface is then flattened or turned inside
            out. (An open mesh's cone volume, ``allow_open``, may have either sign.)
        out : (V, 3) float64 array, optional
            the frame's vertices are written into this array (C-contiguous,
            writable, sharing no memory with the inputs), bit for bit those of a
            call without it, and ``result.vertices`` is this array: a frame loop
            that passes the same array every time allocates no vertex output.
            It is written only by a frame that succeeds (with ``on_fold="raise"``
            it holds the refused frame). Without ``out`` a frame may reuse the
            vertex array of an earlier frame once nothing holds that array any more
            (no reference, view or result; ``vpffd._spare``): results are never
            overwritten, only raw addresses taken from dropped arrays go stale. On
            "vulkan" the array is the host memory the device read the vertices
            back into (no copy on the host): the same rule, and it stays valid
            after the Deformer is gone.
        out_normals : (V, 3) float64 array, optional
            the same for ``result.normals`` (with ``normals=True``).
        method : {"traversal", "csr"}
            how the coefficients are computed (same result to ~1e-12). The
            "vulkan" backend always runs the traversal: it accepts "csr" (refused
            on an open mesh, as on the CPU) and reports ``method="traversal"``.
        rounds : int
            cycle through ``axes`` this many times, each step taking an equal share
            of the volume still missing: 1 is the paper's method; 3-4 rounds spread
            the correction evenly (with "xy" the paper's order widens x more than y).
            Exact either way; each extra round costs one more pass per axis.
        allow_open : bool
            correct the "volume" of a mesh that is not closed (with a warning):
            the cone volume from the lattice centre, which depends on that centre.
        on_fold : {"ignore", "warn", "raise"}
            check the *corrected* control points for fold-over (``check_folds``:
            about 10 ms on two cores for a 10^3 cubic lattice, 20-30 on one,
            ``bench/python/bench_folds.py``; then det J at the vertices, about
            six plain FFDs) and put the report in
            ``result.folds``. "warn" emits a ``FoldWarning`` naming the folded
            cell, "raise" raises ``FoldError`` (its ``report`` attached) and keeps
            the previous frame (on "vulkan" the device's vertices are put back).
            Only a proven fold triggers; undecided cells do not.
        normals : bool
            also return ``result.normals``, the (V, 3) unit normals of the deformed
            surface (``vpffd.normals.deformed_normals`` of the corrected control
            points, method "exact"). "vulkan" computes them in float32 on the device
            in the same submission (angle to the CPU's bounded in
            tests/python/gpu_bounds.py: well under 0.01 degree for a moderate edit).

        Raises
        ------
        InvalidInputError
            bad shapes, NaN, weights <= 0, an open mesh with preserve_volume, ...
        SolverError
            no correction exists (all coefficients zero, dependent constraints,
            more conditions than free control points).
        FoldError
            ``on_fold="raise"`` and the corrected lattice folds.
        """
        t_start = time.perf_counter()
        if not isinstance(preserve_volume, (bool, np.bool_)):
            raise TypeError(f"preserve_volume: expected a bool, got {type(preserve_volume).__name__}")
        if not isinstance(axes, str):
            raise TypeError(f"axes: expected a string such as 'xyz', got {type(axes).__name__}")
        _folds.check_on_fold(on_fold)
        if not isinstance(normals, (bool, np.bool_)):
            raise TypeError(f"normals: expected a bool, got {type(normals).__name__}")
        if not isinstance(allow_inversion, (bool, np.bool_)):
            raise TypeError(f"allow_inversion: expected a bool, got {type(allow_inversion).__name__}")
        P = self._P(control_points)
        nv = self._mesh.n_vertices
        inputs = [("control_points", P), ("control_points", control_points), ("weights", weights),
                  ("fixed", fixed)]
        out = _arrays.out_array(out, nv, "deform: out", inputs)
        out_normals = _arrays.out_array(out_normals, nv, "deform: out_normals", inputs + [("out", out)])
        if out_normals is not None and not normals:
            raise InvalidInputError("deform: out_normals is given but normals=False; pass normals=True")
        w, fx = correction_arrays(self, P, weights, fixed)
        pairs = _arrays.constraint_pairs(constraints, nv)
        cons = [(s, np.zeros(3), t) if isinstance(s, int) else (-1, s, t) for s, t in pairs]
        if isinstance(rounds, bool) or not isinstance(rounds, (int, np.integer)):
            raise TypeError(f"rounds: expected an integer, got {type(rounds).__name__}")
        tv = None
        part_targets = None
        if target_volume is not None and self._core.has_parts and np.ndim(target_volume) > 0:
            arr = np.asarray(target_volume)
            if not _arrays.is_real(arr.dtype):
                raise TypeError(f"target_volume: expected numbers, got dtype {arr.dtype}")
            if arr.shape != (self._core.n_parts,):
                raise InvalidInputError(f"target_volume: expected one volume per part ({self._core.n_parts}), "
                                        f"got shape {arr.shape}")
            part_targets = [float(v) for v in arr]
            if not np.isfinite(part_targets).all():
                raise InvalidInputError(f"target_volume: expected finite numbers, got {arr}")
        elif target_volume is not None:
            if isinstance(target_volume, (bool, np.bool_)) or not isinstance(
                    target_volume, (int, float, np.integer, np.floating)):
                raise TypeError(f"target_volume: expected a number, got {type(target_volume).__name__}")
            tv = float(target_volume)
            if not np.isfinite(tv):
                raise InvalidInputError(f"target_volume: expected a finite number, got {target_volume}")
        if preserve_volume and not allow_open and not self._core.is_closed:
            # The core refuses this too; here the whole defect report (Mesh.check) says
            # what to repair, not just that the mesh is open.
            raise InvalidInputError(
                "deform: the mesh does not bound a volume, so it cannot be preserved "
                f"(pass allow_open=True to keep the cone volume from the lattice centre):\n{self.mesh.check()}")
        if allow_open and preserve_volume and not self._core.is_closed:
            warnings.warn("deform: the mesh is not closed; the volume kept is that of the cone from the lattice "
                          "centre, which depends on where that centre is", stacklevel=2)
        opts = self._frame_options(bool(preserve_volume), axes, w, fx, cons, tv, part_targets, method,
                                   bool(allow_open), int(rounds), bool(allow_inversion))
        if self._vk is not None:
            # Without out= the vertices are the device's read-back memory itself (no
            # copy): the core reuses it once nobody holds the array, so no spare here.
            r = self._vk.deform(P, opts, normals=bool(normals), out=out, out_normals=out_normals)
        else:
            into = out if out is not None else self._spares.take("deform", (nv, 3))
            r = self._core.deform(P, opts, into)
            if out is None:
                self._spares.keep("deform", r["vertices"])
        folds = _folds.check_frame(self, r["control_points"], on_fold, self._restore_last_frame)
        if self._vk is not None:
            self._last_frame = (np.array(P), opts)  # P may be a view of the caller's array
        holder = self._holder
        if not (self._core.is_closed or allow_open):
            rest = float("nan")
        elif holder.rest_volume_known:
            rest = holder.rest_volume(True)
        else:
            # Summed when the result's rest_volume is first read, if ever (result.py).
            rest = self._rest_source
            self._rest_sources_out.add(rest)
        result = DeformResult(
            vertices=r["vertices"],
            control_points=r["control_points"].reshape(*self.lattice.shape, 3),
            offsets=r["offsets"].reshape(*self.lattice.shape, 3),
            volume=r["volume"], volume_before=r["volume_before"], target_volume=r["target_volume"],
            rest_volume=rest, constraint_error=r["constraint_error"], steps=r["steps"],
            # The device always runs the traversal: report what ran, not what was asked.
            backend=self.backend, method="traversal" if self._vk is not None else method, folds=folds,
            faces=self._mesh.faces, normals=self._frame_normals(r, normals, out_normals),
            part_volumes=r.get("part_volumes"),
            part_volumes_before=r.get("part_volumes_before"), part_target_volumes=r.get("part_targets"),
            constraints=self._constraint_points(pairs))
        self._last_python_ms = 1e3 * (time.perf_counter() - t_start)
        return result

    def _constraint_points(self, pairs):
        """(sources (k, 3), targets (k, 3)) read-only, the rest-space points and their
        targets (a vertex source as its rest position), or None without constraints."""
        if not pairs:
            return None
        X = self.mesh.vertices if any(isinstance(s, int) for s, _ in pairs) else None
        S = np.array([X[s] if isinstance(s, int) else s for s, _ in pairs], dtype=np.float64)
        T = np.array([t for _, t in pairs], dtype=np.float64)
        S.setflags(write=False)
        T.setflags(write=False)
        return S, T

    def _frame_options(self, preserve_volume, axes, w, fx, cons, tv, part_targets, method, allow_open, rounds,
                       allow_inversion=False):
        """The one place a frame's options are named; every backend takes the same object.
        Frames without weights, fixed points, constraints or targets share one per setting."""
        key = None
        if w is None and fx is None and not cons and tv is None and part_targets is None:
            key = (preserve_volume, axes, method, allow_open, rounds, allow_inversion)
            opts = self._plain_options.get(key)
            if opts is not None:
                return opts
        opts = _core.CorrectionOptions(preserve_volume=preserve_volume, axes=axes, weights=w, fixed=fx,
                                       constraints=cons, target_volume=tv, part_targets=part_targets,
                                       method=method, threads=self._threads, allow_open=allow_open, rounds=rounds,
                                       allow_inversion=allow_inversion)
        if key is not None and len(self._plain_options) < 64:
            self._plain_options[key] = opts
        return opts

    def _frame_normals(self, r, wanted, out=None):
        """The frame's normals: the device's, or on the CPU deformed_normals of its control points."""
        if not wanted:
            return None
        if "normals" in r:
            return r["normals"]
        from .normals import deformed_normals
        return deformed_normals(self, r["control_points"], out=out)

    def _restore_last_frame(self) -> None:
        """Vulkan: runs the last kept frame again (the rest shape before any), so
        the device's vertices are those of the previous result again."""
        if self._vk is None:
            return
        if self._last_frame is None:
            rest = np.ascontiguousarray(self.lattice.rest_points.reshape(-1, 3))
            plain = _core.CorrectionOptions(preserve_volume=False, threads=self._threads)
            self._vk.deform(rest, plain, read_vertices=False)
        else:
            P, opts = self._last_frame
            self._vk.deform(P, opts, read_vertices=False)

    @_frame
    def check_folds(self, control_points=None, depth: int = _folds.DEFAULT_DEPTH, threads=None):
        """Fold-over check of the lattice with ``control_points`` (default the
        lattice's; pass ``result.control_points`` for a corrected frame), plus det J
        at the mesh vertices (``vertex_min_det``). See ``vpffd.check_folds``."""
        return _folds.check_deformer_folds(self, control_points, depth, threads)

    @property
    def device(self):
        """The Vulkan device dict (see ``vulkan_devices()``), or None on the CPU."""
        return self._vk.device if self._vk is not None else None

    @property
    def gpu_precision(self):
        """How the Vulkan device sums: "float64" or "float-float"; None on the CPU."""
        return self._vk.precision if self._vk is not None else None

    def last_timings(self):
        """Vulkan only: times of the last frame in ms (``gpu_total_ms`` from timestamp
        queries, ``gpu_ffd_ms``, ``gpu_steps_ms`` per axis, ``host_total_ms`` the core's
        call end to end; ``gpu_move_ms``: the device embedding, cell sort and tiles of a
        ``set_rest_vertices`` that ran first in this frame's submission, not part of
        ``gpu_total_ms``, 0.0 when no move waited for the frame; ``gpu_readback_ms``: the
        read back's device work after the frame, the vertices put in the caller's order
        and copied to host memory, 0.0 without vertices).

        The host's stages: ``host_prepare_ms`` (checks, plan, staging the control points
        and frame data in mapped memory), ``host_submit_wait_ms`` (submission until the
        queue is idle: the device's work and the driver's around it),
        ``host_unpack_ms`` (the read back into the caller's array, in float64),
        and ``python_total_ms``, the whole ``deform`` call (the Python checks, the
        result's arrays and the fold check on top of ``host_total_ms``). With frames on
        several threads these are of the last frame to finish."""
        if self._vk is None:
            raise InvalidInputError("last_timings: only the 'vulkan' backend records frame timings")
        t = self._vk.last_timings()
        t["python_total_ms"] = self._last_python_ms
        return t

    def __repr__(self) -> str:
        return f"Deformer({self.mesh!r}, {self.lattice!r}, backend={self.backend!r})"


def correction_arrays(deformer, P, weights, fixed):
    """``(weights, fixed)`` of a frame as the core takes them: per-control-point arrays
    (float, bool) or None; ``weights="auto"`` becomes the local weights of ``P``."""
    n, shape = deformer.n_control_points, deformer.lattice.shape
    if isinstance(weights, str):
        if weights != "auto":
            raise InvalidInputError(f"weights: expected an array or 'auto', got {weights!r}")
        weights = _local_weights.auto_weights(deformer, P)
    w = None if weights is None else _arrays.per_control_point(weights, n, shape, "weights", float)
    fx = None if fixed is None else _arrays.per_control_point(fixed, n, shape, "fixed", bool)
    return w, fx
