"""Blender lattice <-> vpffd lattice bookkeeping, without bpy (plain numpy).

Blender stores a lattice's points as one flat list with u running fastest, then
v, then w: point ``i + nu * (j + nv * k)`` is grid point (i, j, k). vpffd keeps
control points as an (nu, nv, nw, 3) array indexed [i, j, k]. Both live in the
lattice object's local space; Blender's rest points (``LatticePoint.co``) are a
regular grid spanning the lattice's local box, which becomes vpffd's box.

Blender interpolates its points with uniform B-splines whose indices are clamped
at the border, so its rest grid is not the control net of vpffd's open
(clamped) B-spline lattice. The add-on therefore shows vpffd's own control
points (Greville abscissae at rest) as the Blender lattice's points: what the
artist moves is exactly what vpffd deforms.
"""
from __future__ import annotations

import numpy as np


def blender_to_grid(flat, shape) -> np.ndarray:
    """(nu*nv*nw, 3) points in Blender order (u fastest) -> (nu, nv, nw, 3) float64."""
    nu, nv, nw = (int(n) for n in shape)
    flat = np.asarray(flat, dtype=np.float64)
    if flat.size != nu * nv * nw * 3:
        raise ValueError(f"expected {nu * nv * nw} points for a {nu}x{nv}x{nw} lattice, got {flat.size / 3:g}")
    # C order over (w, v, u) makes u the fastest index, as Blender stores it.
    return np.ascontiguousarray(flat.reshape(nw, nv, nu, 3).transpose(2, 1, 0, 3))


def grid_to_blender(grid) -> np.ndarray:
    """(nu, nv, nw, 3) -> (nu*nv*nw, 3) in Blender order (u fastest); inverse of blender_to_grid."""
    grid = np.asarray(grid, dtype=np.float64)
    if grid.ndim != 4 or grid.shape[3] != 3:
        raise ValueError(f"expected an (nu, nv, nw, 3) array, got shape {grid.shape}")
    return np.ascontiguousarray(grid.transpose(2, 1, 0, 3).reshape(-1, 3))


def scalars_to_grid(values, shape) -> np.ndarray:
    """Per-point scalars in Blender order -> (nu, nv, nw)."""
    nu, nv, nw = (int(n) for n in shape)
    values = np.asarray(values, dtype=np.float64)
    if values.size != nu * nv * nw:
        raise ValueError(f"expected {nu * nv * nw} values, got {values.size}")
    return np.ascontiguousarray(values.reshape(nw, nv, nu).transpose(2, 1, 0))


def lattice_box(rest_co) -> tuple:
    """(box_min, box_max) in lattice-local units: the extent of Blender's rest grid.

    Raises ValueError when the grid is flat along an axis (one point, or a
    zero-size lattice), which no solid lattice can represent."""
    co = np.asarray(rest_co, dtype=np.float64).reshape(-1, 3)
    lo, hi = co.min(axis=0), co.max(axis=0)
    for a in range(3):
        if not hi[a] > lo[a]:
            raise ValueError(f"the lattice is flat along its local {'xyz'[a]} axis (it needs at least 2 points "
                             "and a non-zero size along every axis)")
    return lo, hi


def degrees_for(shape, degree: int) -> tuple:
    """Per-axis B-spline degree: ``degree`` where the axis has enough points, else n - 1."""
    return tuple(int(max(1, min(degree, n - 1))) for n in shape)


def rebased_points(current, displayed_rest, new_rest) -> np.ndarray:
    """Control points that keep the artist's offsets when the rest net changes.

    ``current`` are the points as shown, ``displayed_rest`` what they were offset
    from (Blender's rest grid before the first binding, or vpffd's previous rest
    net), ``new_rest`` vpffd's rest control points. All (nu, nv, nw, 3)."""
    current = np.asarray(current, dtype=np.float64)
    return np.asarray(new_rest, dtype=np.float64) + (current - np.asarray(displayed_rest, dtype=np.float64))


def group_weights(group_weight) -> tuple:
    """(weights, fixed) for vpffd.Deformer.deform from a lattice vertex group's weights.

    A group weight g in [0, 1] is how stiff a control point is: g = 1 keeps the
    point where the artist put it (``fixed``), g = 0 lets it take a full share of
    the volume correction. In vpffd's weighted least squares a point's offset
    scales as 1 / weight, so weight = 1 / (1 - g) makes the offset scale as
    (1 - g). Returns (weights, fixed) with the input's shape; None for fixed when
    no point has g = 1."""
    g = np.asarray(group_weight, dtype=np.float64)
    if not np.isfinite(g).all():
        raise ValueError("group weights contain NaN or Inf")
    g = np.clip(g, 0.0, 1.0)
    fixed = g >= 1.0
    weights = 1.0 / np.where(fixed, 1.0, 1.0 - g)
    return weights, (fixed if fixed.any() else None)


def affine(matrix, points) -> np.ndarray:
    """Applies a 4x4 affine matrix to (n, 3) points (float64)."""
    M = np.asarray(matrix, dtype=np.float64).reshape(4, 4)
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return P @ M[:3, :3].T + M[:3, 3]


def outside_count(points, box_min, box_max) -> int:
    """How many of the (n, 3) points lie outside the closed box."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    inside = np.all((P >= np.asarray(box_min)) & (P <= np.asarray(box_max)), axis=1)
    return int(P.shape[0] - np.count_nonzero(inside))

