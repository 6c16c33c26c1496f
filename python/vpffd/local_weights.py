"""Automatic local volume correction (000_4f6fff734e8a30e3.txt, §8):
correction weights derived from where the plain FFD changed the volume.

For each face f let dV_f = |V_f(deformed) - V_f(rest)|, with V_f the signed
volume of the cone from the lattice centre over f (their sum is the enclosed
volume). Each face shares dV_f among the control points that move it,
in proportion to its vertices' basis functions:

    L_c = sum_f dV_f * (1/3) sum_{v in f} B_c(v),

so sum_c L_c = sum_f dV_f (the B_c sum to one). With r_c = L_c / max L in
[0, 1], the weights are

    w_c = 1 / (r_c^2 + eps),  eps = 1e-6.

The weighted least-squares step (Remark 2) moves control point c by an amount
proportional to alpha_c / w_c = alpha_c (r_c^2 + eps): control points whose
support changed no volume move a millionth as much as the most changed ones,
and the square keeps points at the fringe of an edit (small r_c) nearly still.
The volume is still corrected exactly (the weights only choose which exact
solution). Without any volume change (max L below 1e-12 of the summed
|cone volumes|, i.e. rounding) the weights are uniform.
"""
from __future__ import annotations

import numpy as np

AUTO_EPS = 1e-6


def face_volume_changes(deformer, deformed_vertices) -> np.ndarray:
    """(F,) |V_f(deformed) - V_f(rest)| of the cones from the lattice centre."""
    c = deformer.lattice.center
    F = deformer.mesh.faces

    def cones(X):
        a, b, d = (X[F[:, i]] - c for i in range(3))
        return np.einsum("ij,ij->i", a, np.cross(b, d)) / 6.0

    return np.abs(cones(deformed_vertices) - cones(deformer.mesh.vertices))


def local_volume_change(deformer, control_points=None) -> np.ndarray:
    """(N,) L_c: each control point's share of the volume change of the plain FFD
    over its support (formula in the module docstring), in volume units."""
    dV = face_volume_changes(deformer, deformer.ffd(control_points))
    F = deformer.mesh.faces
    per_vertex = np.zeros(deformer.mesh.n_vertices)
    for i in range(3):
        np.add.at(per_vertex, F[:, i], dV / 3.0)
    # The support of each distinct control point (its periodic copies' included).
    B = deformer.lattice._fold_columns(deformer._extended_basis())
    return np.asarray(B.T @ per_vertex).reshape(-1)


def auto_weights(deformer, control_points=None):
    """(N,) correction weights w_c = 1 / (r_c^2 + 1e-6), r_c = L_c / max L, or None
    (uniform) when the plain FFD changed no face's volume."""
    L = local_volume_change(deformer, control_points)
    top = float(L.max()) if L.size else 0.0
    # Rounding alone changes a face's cone volume by ~1e-16 of it; below 1e-12 of
    # the total there is no edit to follow.
    c = deformer.lattice.center
    X, F = deformer.mesh.vertices, deformer.mesh.faces
    scale = float(np.abs(np.einsum("ij,ij->i", X[F[:, 0]] - c, np.cross(X[F[:, 1]] - c, X[F[:, 2]] - c))).sum()) / 6
    if not (np.isfinite(top) and top > 1e-12 * scale):
        return None
    r = L / top
    return 1.0 / (r * r + AUTO_EPS)
