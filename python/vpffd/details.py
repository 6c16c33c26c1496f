"""How a deformation treats the details of a multiresolution decomposition (paper
002, Fig. 6): a fine vertex is its base point plus a normal displacement,
p = S(t) + d N_S(t). After an edit D of the base, the vertex's *detail* is what
separates it from the deformed base point S'(t) = D(S(t)):

    multiresolution:  p' - S'(t) = d N_S'(t)       (height |d| and direction kept)
    plain FFD:        D(p) - S'(t) = J_D d N_S + ... (stretched, sheared, tilted)

``detail_change`` measures both effects for any deformed fine vertices: how much
the detail height changed, relative to |d|, and the angle between the detail and
the deformed base normal.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core

InvalidInputError = _core.InvalidInputError


@dataclass(frozen=True)
class DetailChange:
    """Detail change over the measured vertices (those with |d| >= ``min_height`` of
    the largest |d|: the bumps, not the flat parts whose direction is noise).

    Attributes
    ----------
    height_change_mean, height_change_max : float
        | |p' - S'| - |d| | / |d|, a fraction (0.25: a quarter taller or shorter).
    angle_mean_deg, angle_max_deg : float
        angle between p' - S' and sign(d) N_S', degrees (0: the detail stands
        along the deformed base normal).
    n_measured : int
        vertices measured.
    """
    height_change_mean: float
    height_change_max: float
    angle_mean_deg: float
    angle_max_deg: float
    n_measured: int


def detail_change(deformer, vertices, control_points=None, min_height: float = 0.2) -> DetailChange:
    """Detail change of deformed fine vertices against the base deformed by P.

    Parameters
    ----------
    deformer : MultiresDeformer
        its decomposition gives d, and its lattice the map of the base.
    vertices : (V, 3) float
        the deformed fine mesh: a MultiresResult's ``vertices``, or a plain FFD of
        the fine mesh (``Deformer.deform(P).vertices``).
    control_points : (nu, nv, nw, 3) or (N, 3), optional
        the control points that moved those vertices (after any volume
        correction: each method's own); default the lattice's.
    min_height : float in (0, 1]
        vertices with |d| below this fraction of max |d| are not measured.
    """
    if not 0 < min_height <= 1:
        raise InvalidInputError(f"detail_change: min_height must be in (0, 1], got {min_height!r}")
    d = np.asarray(deformer.multires.displacements)
    X = np.asarray(vertices, dtype=np.float64)
    if X.shape != (d.size, 3):
        raise InvalidInputError(f"detail_change: vertices: expected shape ({d.size}, 3), got {X.shape}")
    top = float(np.abs(d).max())
    if not top > 0:
        raise InvalidInputError("detail_change: the decomposition has no displacements (the mesh is its base)")
    S, N = deformer.foot_frames(control_points)
    keep = np.abs(d) >= min_height * top
    detail = (X - S)[keep]
    h = np.linalg.norm(detail, axis=1)
    rel = np.abs(h - np.abs(d[keep])) / np.abs(d[keep])
    n = N[keep] * np.sign(d[keep])[:, None]
    ang = np.degrees(np.arctan2(np.linalg.norm(np.cross(detail, n), axis=1), np.einsum("ij,ij->i", detail, n)))
    return DetailChange(height_change_mean=float(rel.mean()), height_change_max=float(rel.max()),
                        angle_mean_deg=float(ang.mean()), angle_max_deg=float(ang.max()), n_measured=int(keep.sum()))
