"""Fold-over certification of a lattice (Hahmann et al. 2012, §8).

A B-spline FFD folds (turns space inside out) where det J < 0, J = dD/dx. On
every lattice cell det J is a polynomial of degree 3d-1 per axis; its
Bernstein coefficients are computed exactly up to a proven rounding bound.
All of them positive proves the cell fold-free; a negative corner value is a
point where it folds; anything else is subdivided (de Casteljau at 1/2) up to
``depth`` levels and may stay "unknown". See cpp/include/vpffd/folds/.
"""
from __future__ import annotations

import numpy as np

from . import _arrays, _core

InvalidInputError = _core.InvalidInputError

#: per-cell status values of ``FoldReport.status``
FOLDED, UNKNOWN, CERTIFIED = -1, 0, 1
DEFAULT_DEPTH = 3
MAX_DEPTH = _core.max_fold_depth


class FoldError(RuntimeError):
    """Raised by ``Deformer.deform(..., on_fold="raise")`` when the corrected
    lattice folds. ``report`` is the FoldReport."""

    def __init__(self, message, report=None):
        super().__init__(message)
        self.report = report


class FoldWarning(UserWarning):
    """Emitted by ``Deformer.deform(..., on_fold="warn")`` when the corrected lattice folds."""


class FoldReport:
    """What ``check_folds`` found.

    Attributes
    ----------
    certified : bool
        det J > 0 is proven on the whole lattice domain.
    folded : bool
        a point with det J < 0 was found (never together with ``certified``).
    witness : (3,) float64 or None
        a rest-space point where det J < 0 (inside a folded cell, near the
        corner where the fold was found).
    witness_det : float or None
        det J at the witness (world units: deformed volume per rest volume).
    witness_cell : (i, j, k) or None
    status : (cu, cv, cw) int8
        per cell: FOLDED (-1), UNKNOWN (0) or CERTIFIED (1). Cells are the
        non-empty knot spans (cu = nu - du for open-uniform knots).
    cell_edges : three 1-D arrays
        rest-space boundaries of the cells along x, y, z (cu+1, cv+1, cw+1 values).
    cell_min_det, cell_lower_bound : (cu, cv, cw) float64
        smallest det J met at a point of the cell, and a proven lower bound of
        det J over it (the true minimum lies between).
    cell_subcells : (cu, cv, cw) int32
        subcells examined per cell (1: no refinement needed).
    min_det, lower_bound : float
        the same over the whole lattice.
    n_cells, n_certified, n_folded, n_unknown, n_refined, n_subcells : int
    vertex_min_det : float or None
        smallest det J at the mesh vertices (``Deformer.check_folds`` only).
    vertex_argmin : int or None
        the vertex where it is.
    depth : int
    time_ms : float
        wall time of the check (the vertex pass included when present).
    occupied : (cu, cv, cw) bool or None
        ``Deformer.check_folds`` only: the cells holding part of the mesh (surface or,
        closed, inside); ``mesh_folded`` says whether a fold is there. ``verdict()``
        words both.

    A report is safe to share between threads once ``occupied`` has been read (the
    first read computes and stores it; two threads reading it first compute it twice).
    """

    def __init__(self, d: dict, lattice):
        self.certified = bool(d["certified"])
        self.folded = bool(d["folded"])
        self.status = d["status"]
        self.cell_min_det = d["cell_min_det"]
        self.cell_lower_bound = d["cell_lower_bound"]
        self.cell_subcells = d["cell_subcells"]
        for a in (self.status, self.cell_min_det, self.cell_lower_bound, self.cell_subcells):
            a.setflags(write=False)
        self.cells = tuple(int(c) for c in d["cells"])
        self.spans = tuple(np.asarray(s, dtype=np.int64) for s in d["spans"])
        self.witness = np.array(d["witness"], dtype=np.float64) if d["has_witness"] else None
        self.witness_parameters = np.array(d["witness_param"], dtype=np.float64) if d["has_witness"] else None
        self.witness_det = float(d["witness_det"]) if d["has_witness"] else None
        self.witness_cell = tuple(int(c) for c in d["witness_cell"]) if d["has_witness"] else None
        self.min_det = float(d["min_det"])
        self.lower_bound = float(d["lower_bound"])
        self.n_certified = int(d["n_certified"])
        self.n_folded = int(d["n_folded"])
        self.n_unknown = int(d["n_unknown"])
        self.n_refined = int(d["n_refined"])
        self.n_subcells = int(d["n_subcells"])
        self.n_cells = int(np.prod(self.cells))
        self.depth = int(d["depth"])
        self.time_ms = 1e3 * float(d["seconds"])
        self.vertex_min_det = None
        self.vertex_argmin = None
        # With a mesh (Deformer.check_folds): its rest vertices and faces, the cells it
        # occupies (computed when first needed) and whether a vertex decided the fold.
        self._mesh = None
        self._occupied = None
        self._vertex_fold = False
        edges = []
        for a, (t, s) in enumerate(zip(lattice.knots, self.spans)):
            u = np.append(t[s], t[s[-1] + 1]) if len(s) else np.zeros(0)
            lo, hi = t[lattice.degree[a]], t[len(t) - lattice.degree[a] - 1]
            edges.append(lattice.box_min[a] + (u - lo) / (hi - lo) * (lattice.box_max[a] - lattice.box_min[a]))
        self.cell_edges = tuple(edges)
        # Periodic axes: a rest point is in the cell of its wrapped twin.
        self._wrap = lattice._spec.wrap_points if lattice.periodic else None

    @property
    def folded_cells(self) -> np.ndarray:
        """(n, 3) indices (i, j, k) of the folded cells."""
        return np.argwhere(self.status == FOLDED)

    def cell_of(self, points) -> np.ndarray:
        """(n, 3) int64 cell indices of rest-space points (points outside the box
        get the nearest boundary cell)."""
        X = _arrays.points(points, "FoldReport.cell_of: points", allow_empty=True)
        if self._wrap is not None and len(X):
            X = self._wrap(X)[0]
        out = np.empty((len(X), 3), dtype=np.int64)
        for a in range(3):
            e = self.cell_edges[a]
            out[:, a] = np.clip(np.searchsorted(e, X[:, a], side="right") - 1, 0, len(e) - 2)
        return out

    def status_at(self, points) -> np.ndarray:
        """(n,) int8 status of the cell that holds each rest-space point."""
        c = self.cell_of(points)
        return self.status[c[:, 0], c[:, 1], c[:, 2]]

    @property
    def occupied(self):
        """(cu, cv, cw) bool: the cells that hold part of the mesh (its surface, and for a
        closed mesh its inside too), or None for a check of a lattice alone. Only from
        ``Deformer.check_folds``; computed on first read (``occupied_cells``)."""
        if self._occupied is None and self._mesh is not None:
            self._occupied = occupied_cells(self, self._mesh)
            self._occupied.setflags(write=False)
        return self._occupied

    @property
    def mesh_folded(self):
        """True when the deformation folds where the mesh is: a folded cell holds part of
        it, or det J is proven negative at a vertex; False when every fold is in cells
        the mesh does not occupy (or there is none); None for a lattice alone."""
        if self._mesh is None:
            return None
        if not self.folded:
            return False
        if self._vertex_fold:
            return True
        return bool((self.occupied & (self.status == FOLDED)).any())

    def _mesh_counts(self):
        """(folded, undecided, occupied) cell counts within the mesh's cells."""
        occ = self.occupied
        return (int((occ & (self.status == FOLDED)).sum()), int((occ & (self.status == UNKNOWN)).sum()),
                int(occ.sum()))

    def verdict(self, short: bool = False) -> str:
        """The fold verdict in one line: the line the command line prints, and (with
        ``short``: its first part, without the numbers) the pictures' captions and the
        results' reprs. With a mesh (``Deformer.check_folds``) it says separately
        whether cells the mesh occupies fold ("FOLDS in the mesh's cells": the fold may
        still miss the mesh's own points within them) or only cells it
        does not occupy ("folds only outside the mesh": no point of the mesh moves
        through such a fold)."""
        t = f"{self.time_ms:.1f} ms"
        where = ""
        if self.folded:
            i, j, k = self.witness_cell
            x = ", ".join(f"{v:.4g}" for v in self.witness)
            where = f"det J = {self.witness_det:.3g} at ({x}) in cell ({i}, {j}, {k})"
        if self.certified:
            head = "fold-free (proven)"
            detail = f"det J >= {self.lower_bound:.3g} on all {self.n_cells} cells"
        elif self._mesh is None:
            if self.folded:
                head = f"FOLDS in {self.n_folded} of {self.n_cells} cells"
                detail = where
            else:
                head = f"undecided in {self.n_unknown} of {self.n_cells} cells"
                detail = (f"depth {self.depth}; det J >= {self.lower_bound:.3g}, smallest found "
                          f"{self.min_det:.3g}")
        else:
            n_fold, n_unknown, n_occ = self._mesh_counts()
            vert = "" if self.vertex_min_det is None else f"; min det J at the vertices {self.vertex_min_det:.3g}"
            if self.mesh_folded:
                head = (f"FOLDS in the mesh's cells ({n_fold} of its {n_occ})" if n_fold else
                        f"FOLDS at the mesh (det J < 0 at vertex {self.vertex_argmin})")
                detail = f"{where}; {self.n_folded} of {self.n_cells} lattice cells fold{vert}"
            elif self.folded:
                head = f"folds only outside the mesh ({self.n_folded} cells it does not occupy)"
                if n_unknown:
                    head += f"; {n_unknown} of its {n_occ} cells undecided"
                detail = f"{self.n_folded} of {self.n_cells} lattice cells fold; {where}{vert}"
            else:
                head = (f"undecided in {n_unknown} of the mesh's {n_occ} cells" if n_unknown else
                        f"no fold in the mesh's {n_occ} cells; {self.n_unknown} empty cells undecided")
                detail = (f"{self.n_unknown} of {self.n_cells} lattice cells undecided at depth {self.depth}; "
                          f"det J >= {self.lower_bound:.3g}, smallest found {self.min_det:.3g}{vert}")
        return head if short else f"{head}: {detail} ({t})"

    def __bool__(self):
        raise TypeError("FoldReport has no truth value: use .certified or .folded")

    def __repr__(self) -> str:
        vert = "" if self.vertex_min_det is None else f", vertex_min_det={self.vertex_min_det:.6g}"
        return (f"FoldReport({self.verdict(short=True)}; cells={self.cells}, "
                f"certified/folded/unknown={self.n_certified}/{self.n_folded}/{self.n_unknown}, "
                f"min_det={self.min_det:.6g}, lower_bound={self.lower_bound:.6g}{vert}, depth={self.depth})")


def occupied_cells(report: FoldReport, mesh) -> np.ndarray:
    """(cu, cv, cw) bool: the cells of ``report`` that hold part of ``mesh`` (rest
    positions): every cell a triangle touches (exact triangle-box overlap, cells
    closed), and for a closed mesh every cell inside it. Cells no triangle touches
    form connected groups that lie wholly inside or wholly outside a closed surface;
    one winding number per group decides which. On a periodic lattice the cells of
    the vertices and of points on the faces no farther apart than a quarter of the
    narrowest cell count, without the inside."""
    from .mesh import Mesh
    m = Mesh.from_any(mesh)
    V, F = m.vertices, m.faces
    occ = np.zeros(report.status.shape, dtype=bool)
    if report._wrap is not None:
        for X in _face_samples(V, F, 0.25 * min(float(np.diff(e).min()) for e in report.cell_edges)):
            c = report.cell_of(X)
            occ[c[:, 0], c[:, 1], c[:, 2]] = True
        return occ
    T = V[F]  # (F, 3 corners, 3)
    lo, hi = T.min(axis=1), T.max(axis=1)
    first = np.empty((len(F), 3), np.int64)
    last = np.empty((len(F), 3), np.int64)
    for a, e in enumerate(report.cell_edges):
        n = len(e) - 1
        # Closed cells: a triangle reaching a cell wall touches the cells on both sides.
        first[:, a] = np.clip(np.searchsorted(e, lo[:, a], side="left") - 1, 0, n - 1)
        last[:, a] = np.maximum(np.clip(np.searchsorted(e, hi[:, a], side="right") - 1, 0, n - 1), first[:, a])
    one = (first == last).all(axis=1)
    occ[first[one, 0], first[one, 1], first[one, 2]] = True
    many = np.flatnonzero(~one)
    # Triangles across cell walls: each against the cells of its bounding box, in
    # chunks of about a million pairs.
    counts = np.prod(last[many] - first[many] + 1, axis=1)
    start = 0
    while start < len(many):
        stop = start + max(1, int(np.searchsorted(np.cumsum(counts[start:]), 1 << 20)))
        t = np.repeat(many[start:stop], counts[start:stop])
        local = np.arange(len(t)) - np.repeat(np.cumsum(counts[start:stop]) - counts[start:stop], counts[start:stop])
        span = last[t] - first[t] + 1
        cell = first[t] + np.stack([local // (span[:, 1] * span[:, 2]), (local // span[:, 2]) % span[:, 1],
                                    local % span[:, 2]], axis=1)
        lo_c = np.stack([report.cell_edges[a][cell[:, a]] for a in range(3)], axis=1)
        hi_c = np.stack([report.cell_edges[a][cell[:, a] + 1] for a in range(3)], axis=1)
        hit = _triangles_touch_boxes(T[t], 0.5 * (lo_c + hi_c), 0.5 * (hi_c - lo_c))
        occ[cell[hit, 0], cell[hit, 1], cell[hit, 2]] = True
        start = stop
    if m.is_closed and not occ.all():
        from scipy import ndimage
        groups, n_groups = ndimage.label(~occ)
        for g in range(1, n_groups + 1):
            i, j, k = np.argwhere(groups == g)[0]
            centre = np.array([0.5 * (e[c] + e[c + 1]) for e, c in zip(report.cell_edges, (i, j, k))])
            if abs(_winding_number(centre, T)) > 0.5:
                occ[groups == g] = True
    return occ


def _triangles_touch_boxes(T, c, h) -> np.ndarray:
    """(n,) bool: triangle T[i] (3, 3) meets the closed box of centre c[i] and half
    sizes h[i] (separating axes: the box's, the triangle's normal, the 9 edge
    crosses). Touching counts: each test allows a relative 1e-12 of the box's size,
    so rounding never drops a cell the surface reaches."""
    v = T - c[:, None, :]
    tol = 1e-12 * (np.abs(c).max(axis=1) + h.max(axis=1))
    edges = (v[:, 1] - v[:, 0], v[:, 2] - v[:, 1], v[:, 0] - v[:, 2])
    axes = [np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])]
    for a in range(3):
        unit = np.zeros(3)
        unit[a] = 1.0
        axes.append(np.broadcast_to(unit, c.shape))
        axes += [np.cross(np.broadcast_to(unit, c.shape), e) for e in edges]
    ok = np.ones(len(T), dtype=bool)
    for ax in axes:
        p = np.einsum("nkj,nj->nk", v, ax)
        r = (np.abs(ax) * h).sum(axis=1)
        slack = r + tol * np.abs(ax).sum(axis=1)
        ok &= (p.min(axis=1) <= slack) & (p.max(axis=1) >= -slack)
    return ok


def _winding_number(x, T) -> float:
    """Winding number of the closed triangle soup T (F, 3, 3) about the point x: 1
    inside an outward surface, 0 outside (solid angles, Van Oosterom and Strackee)."""
    a, b, c = T[:, 0] - x, T[:, 1] - x, T[:, 2] - x
    la, lb, lc = (np.linalg.norm(u, axis=1) for u in (a, b, c))
    num = np.einsum("ij,ij->i", a, np.cross(b, c))
    den = (la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", b, c) * la
           + np.einsum("ij,ij->i", c, a) * lb)
    return float(np.arctan2(num, den).sum() / (2 * np.pi))


def _face_samples(V, F, spacing):
    """Points on every face no farther apart than ``spacing`` (the corners included),
    in chunks: barycentric grids of n steps per face, n from its longest edge."""
    T = V[F]
    longest = np.max(np.linalg.norm(T - np.roll(T, 1, axis=1), axis=2), axis=1)
    steps = np.clip(np.ceil(longest / spacing), 1, 64).astype(np.int64)
    for n in np.unique(steps):
        i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
        keep = i + j <= n
        w = np.stack([i[keep], j[keep], n - i[keep] - j[keep]], axis=1) / n  # (s, 3)
        sel = T[steps == n]
        for s in range(0, len(sel), max(1, (1 << 20) // len(w))):
            yield np.einsum("sk,fkj->fsj", w, sel[s:s + max(1, (1 << 20) // len(w))]).reshape(-1, 3)


def _depth(depth) -> int:
    if isinstance(depth, bool) or not isinstance(depth, (int, np.integer)):
        raise TypeError(f"check_folds: depth must be an integer, got {type(depth).__name__}")
    if not 0 <= depth <= MAX_DEPTH:
        raise InvalidInputError(f"check_folds: depth {depth} not in [0, {MAX_DEPTH}]")
    return int(depth)


def check_folds(lattice, control_points=None, depth: int = DEFAULT_DEPTH, threads=None) -> FoldReport:
    """Proves that the FFD of ``lattice`` with ``control_points`` does not fold
    (det J > 0 everywhere in the lattice box), or finds where it does.

    Parameters
    ----------
    lattice : vpffd.Lattice
    control_points : (nu, nv, nw, 3) or (N, 3), optional
        default: ``lattice.control_points``. Not modified.
    depth : int, 0..MAX_DEPTH
        subdivision levels for cells whose Bernstein coefficients do not decide
        (each level splits a cell in 8; at most 4096 subcells per cell).
    threads : int, optional
        OpenMP threads (default all); the report does not depend on it.

    Returns
    -------
    FoldReport
    """
    from .lattice import Lattice
    if not isinstance(lattice, Lattice):
        raise TypeError(f"check_folds: expected a vpffd.Lattice, got {type(lattice).__name__}")
    P = lattice._control(control_points)
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, (int, np.integer))
                                or not 1 <= threads <= 4096):
        raise InvalidInputError(f"check_folds: threads must be an integer in 1..4096 or None, got {threads!r}")
    # A periodic lattice is certified on its extended net: every cell of the box, the
    # seam's included (cell indices are those of the extended lattice).
    return FoldReport(_core.check_folds(lattice._spec, lattice._expand(P), _depth(depth), int(threads or 0)),
                      lattice)


def vertex_folds(deformer, control_points=None, report=None, depth: int = DEFAULT_DEPTH):
    """What a renderer needs to show folds on the mesh: ``(det, status)`` with
    det (V,) float64 det J at each vertex and status (V,) int8 the status of the
    lattice cell that holds it (FOLDED, UNKNOWN, CERTIFIED). ``report``: a
    FoldReport of the same control points (default: checked now)."""
    rep = report if report is not None else check_folds(deformer.lattice, control_points, depth)
    return deformer.jacobian_determinants(control_points), rep.status_at(deformer.mesh.vertices)


# A negative det J at a vertex decides only beyond the rounding of the Jacobian:
# each entry is a sum of (d+1)^3 products of basis derivatives and control point
# coordinates (relative error below 1e-13 of the column's size for d <= 5), so
# det J is within 3 * 1e-13 * (1 + 1e-13)^2 of the Hadamard bound prod |col|.
# 1e-9 of that bound is far above it and far below any real fold.
_VERTEX_DET_TOLERANCE = 1e-9


def check_deformer_folds(deformer, control_points=None, depth: int = DEFAULT_DEPTH, threads=None) -> FoldReport:
    """``check_folds`` of the deformer's lattice plus det J at the mesh vertices
    (``vertex_min_det``). A vertex with det J clearly below zero is a fold too:
    when the cells left it undecided, the report becomes ``folded`` with that
    vertex as the witness."""
    import time
    t0 = time.perf_counter()
    rep = check_folds(deformer.lattice, control_points, depth, threads)
    det = deformer.jacobian_determinants(control_points)
    v = int(np.argmin(det))
    rep.vertex_min_det = float(det[v])
    rep.vertex_argmin = v
    rep._mesh = deformer.mesh
    # The Hadamard bound needs J at that vertex; the (V, 3, 3) Jacobians are only
    # computed when a negative det J can decide.
    undecided = not rep.folded and not rep.certified and det[v] < 0
    hadamard = float(np.prod(np.linalg.norm(deformer.jacobians(control_points)[v], axis=0))) if undecided else 0.0
    if undecided and det[v] < -_VERTEX_DET_TOLERANCE * hadamard:
        # Proven negative at a rest vertex (a certified lattice cannot get here).
        rep.folded = True
        rep._vertex_fold = True
        rep.witness = deformer.mesh.vertices[v].copy()
        rep.witness_parameters = deformer.lattice.parameters(rep.witness[None])[0]
        rep.witness_det = float(det[v])
        rep.witness_cell = tuple(int(c) for c in rep.cell_of(rep.witness[None])[0])
    rep.time_ms = 1e3 * (time.perf_counter() - t0)
    return rep


ON_FOLD = ("ignore", "warn", "raise")


def check_on_fold(on_fold) -> None:
    """Raises for an ``on_fold`` value other than "ignore", "warn", "raise"."""
    if not isinstance(on_fold, str) or on_fold not in ON_FOLD:
        raise InvalidInputError(f"on_fold: expected one of {', '.join(map(repr, ON_FOLD))}, got {on_fold!r}")


def check_frame(deformer, corrected, on_fold: str, restore):
    """The fold check of one ``deform`` frame: None for "ignore", else the report;
    warns or (after ``restore()``) raises when the corrected lattice folds."""
    if on_fold == "ignore":
        return None
    rep = check_deformer_folds(deformer, corrected)
    if rep.folded:
        i, j, k = rep.witness_cell
        x = ", ".join(f"{v:.4g}" for v in rep.witness)
        msg = (f"deform: the corrected lattice folds in cell ({i}, {j}, {k}): det J = {rep.witness_det:.3g} at "
               f"rest point ({x}); {rep.n_folded} of {rep.n_cells} cells fold; "
               f"{'the mesh folds' if rep.mesh_folded else 'none of them holds part of the mesh'}")
        if on_fold == "raise":
            restore()
            raise FoldError(msg, rep)
        import warnings
        warnings.warn(FoldWarning(msg), stacklevel=3)
    return rep
