"""Point drags on a displaced subdivision surface (``vpffd.SubdivisionMultires``):
rest points on or near the detailed mesh and their targets, turned into new control
points.

Each dragged point is snapped to the nearest fine vertex i; the control points move
by the least-norm change that moves that vertex's foot point on the limit surface,
S(t_i) = sum_j phi_j(t_i) c_j, by exactly (target - point). Only the control points
in the snapped vertices' stencils move (about 12 per point for Loop), so the rest of
the surface stays where it was, to the bit.

>>> edit = drag(sm, [[0.0, 0.0, 1.0]], [[0.0, 0.0, 1.3]])  # doctest: +SKIP
>>> r = sm.deform(edit.control_points)  # doctest: +SKIP
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _arrays, _core

InvalidInputError = _core.InvalidInputError


@dataclass(frozen=True)
class DragEdit:
    """New control points for point drags (``drag``).

    Attributes
    ----------
    control_points : (M, 3) float64
        the edited control points (a new array).
    vertices : (k,) int64
        the fine vertex each dragged point snapped to.
    snap_distances : (k,) float64
        distance from each dragged point to its vertex, world units.
    moved : (m,) int64
        the control points that moved (the union of the snapped vertices' stencils).
    """
    control_points: np.ndarray
    vertices: np.ndarray
    snap_distances: np.ndarray
    moved: np.ndarray

    def __repr__(self) -> str:
        k = len(self.vertices)
        snap = f", snapped up to {self.snap_distances.max():.3g} away" if k else ""
        return (f"DragEdit({k} dragged point{'s' * (k != 1)} on vertices {list(map(int, self.vertices[:5]))}"
                f"{' ...' if k > 5 else ''}{snap}; {len(self.moved)} of {len(self.control_points)} control "
                "points moved)")


def drag(sm, points, targets, control_points=None) -> DragEdit:
    """Control points that move the limit surface under each of ``points`` (k, 3)
    by ``targets - points`` (k, 3).

    A point snaps to the nearest fine vertex of ``sm.mesh`` (rest positions); the
    change of the control points is the least-norm solution of
    Phi_rows delta = targets - points, Phi_rows (k x M) the snapped vertices'
    position stencils. The fine vertices then move by that offset plus the change of
    their displacement direction (the normal turns), so they land near, not exactly
    on, the targets; vertices whose stencils miss the moved control points do not
    move at all.

    Parameters
    ----------
    sm : SubdivisionMultires
    points, targets : (k, 3) array_like
        rest points and where they go, world units (not modified).
    control_points : (M, 3), optional
        the control points to edit (default ``sm.control_points``).

    Raises
    ------
    InvalidInputError
        shapes or non-finite values; two points snapping to one vertex, or to
        vertices whose stencils are linearly dependent (no control points move them
        apart).
    """
    P = _arrays.points(points, "drag: points")
    T = _arrays.points(targets, "drag: targets")
    if P.shape != T.shape or len(P) == 0:
        raise InvalidInputError(f"drag: expected as many targets as points (at least one), got {len(T)} targets "
                                f"for {len(P)} points")
    C = np.array(sm.control_points if control_points is None else control_points, dtype=np.float64)
    if C.shape != (sm.n_control, 3):
        raise InvalidInputError(f"drag: control_points must have shape ({sm.n_control}, 3), got {C.shape}")
    V = sm.mesh.vertices
    # Nearest vertex per point: k is a handful, so k passes over V beat building a tree.
    d2 = np.stack([np.einsum("ij,ij->i", V - p, V - p) for p in P])
    idx = np.argmin(d2, axis=1)
    snap = np.sqrt(d2[np.arange(len(P)), idx])
    if len(np.unique(idx)) < len(idx):
        _, first = np.unique(idx, return_index=True)
        dup = sorted(set(range(len(idx))) - set(first.tolist()))[0]
        raise InvalidInputError(f"drag: points {int(np.flatnonzero(idx == idx[dup])[0])} and {dup} both snap to "
                                f"vertex {int(idx[dup])}; drag points farther apart")
    st = sm.stencils()
    cols = np.unique(np.concatenate([st["indices"][st["indptr"][i]:st["indptr"][i + 1]] for i in idx]))
    A = np.zeros((len(idx), len(cols)))  # Phi restricted to the snapped rows and their support
    for r, i in enumerate(idx):
        lo, hi = st["indptr"][i], st["indptr"][i + 1]
        A[r, np.searchsorted(cols, st["indices"][lo:hi])] = st["w"][lo:hi]
    s = np.linalg.svd(A, compute_uv=False)
    if s[-1] <= 1e-9 * s[0]:
        raise InvalidInputError(f"drag: the {len(P)} dragged points snap to vertices the control points cannot "
                                f"move independently (their stencils are linearly dependent); drag points "
                                f"farther apart")
    # Least-norm: delta = A^T (A A^T)^-1 D, the smallest control-point change that
    # moves every snapped foot point exactly by its offset.
    delta = A.T @ np.linalg.solve(A @ A.T, T - P)
    C[cols] += delta
    return DragEdit(control_points=C, vertices=idx.astype(np.int64), snap_distances=snap,
                    moved=cols.astype(np.int64))
