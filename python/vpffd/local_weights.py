"""Automatic local volume correction (Hahmann et al. 2012, Remark 2 and the local
correction its §8 proposes): correction weights derived from where the plain FFD
changed the volume.

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

from . import _arrays, _core

AUTO_EPS = 1e-6


def _rest_cones(deformer):
    """(F,) cone volumes of the rest mesh from the lattice centre and the sum of
    their magnitudes, kept on the deformer for its current rest mesh."""
    cached = deformer._auto_weight_rest
    if cached is None or cached[0] is not deformer.mesh:
        m = deformer.mesh
        cones = _core.cone_volumes(m.vertices, m.faces, deformer.lattice.center, False)
        cached = (m, cones, float(np.abs(cones).sum()))
        deformer._auto_weight_rest = cached
    return cached[1], cached[2]


def _volume_changes(deformer, X, check: bool) -> np.ndarray:
    cones = _core.cone_volumes(X, deformer.mesh.faces, deformer.lattice.center, check)
    return np.abs(cones - _rest_cones(deformer)[0])


def face_volume_changes(deformer, deformed_vertices) -> np.ndarray:
    """(F,) |V_f(deformed) - V_f(rest)| of the cones from the lattice centre."""
    X = _arrays.points(deformed_vertices, "face_volume_changes: deformed_vertices", rows=deformer.mesh.n_vertices)
    return _volume_changes(deformer, X, True)


def local_volume_change(deformer, control_points=None) -> np.ndarray:
    """(N,) L_c: each control point's share of the volume change of the plain FFD
    over its support (formula in the module docstring), in volume units."""
    F = deformer.mesh.faces
    dV = _volume_changes(deformer, deformer.ffd(control_points), False)  # the core's output: checked already
    per_vertex = np.bincount(F.reshape(-1), weights=np.repeat(dV / 3.0, 3), minlength=deformer.mesh.n_vertices)
    # B^T per_vertex over the distinct control points (a periodic point's copies
    # summed), by the core's scatter: no (V, N) basis matrix.
    return deformer._d.basis_transpose(per_vertex, deformer._threads)


def auto_weights(deformer, control_points=None):
    """(N,) correction weights w_c = 1 / (r_c^2 + 1e-6), r_c = L_c / max L, or None
    (uniform) when the plain FFD changed no face's volume."""
    L = local_volume_change(deformer, control_points)
    top = float(L.max()) if L.size else 0.0
    # Rounding alone changes a face's cone volume by ~1e-16 of it; below 1e-12 of
    # the total there is no edit to follow.
    scale = _rest_cones(deformer)[1]
    if not (np.isfinite(top) and top > 1e-12 * scale):
        return None
    r = L / top
    return 1.0 / (r * r + AUTO_EPS)
