"""Normals of rest and deformed surfaces.

Exact deformed normals come from the FFD Jacobian J = dD/dx: the image of the
tangent plane with normal n has normal cof(J) n = det(J) J^-T n (no inverse
needed). The mapped-tangent approximation of the GPU FFD paper
(Schein and Elber, §2.4) maps two tangents by finite differences
instead; it is here for comparison.
"""
from __future__ import annotations

import numpy as np

from . import _arrays, _core
from .mesh import Mesh

InvalidInputError = _core.InvalidInputError


def vertex_normals(mesh) -> np.ndarray:
    """(V, 3) float64 unit normals: area-weighted sums of the face normals around
    each vertex (zero for unreferenced vertices). Counter-clockwise faces seen
    from outside give outward normals."""
    m = Mesh.from_any(mesh)
    return _core.vertex_normals(m.vertices, m.faces)


def deformed_normals(deformer, control_points=None, method: str = "exact", rest_normals=None,
                     eps=None, out=None) -> np.ndarray:
    """(V, 3) unit normals of the deformed surface at the deformed vertices.

    Parameters
    ----------
    deformer : vpffd.Deformer
        gives the rest mesh and the lattice.
    control_points : (nu, nv, nw, 3) or (N, 3), optional
        default: the lattice's current control points. Use
        ``result.control_points`` for the volume-corrected frame.
    method : {"exact", "tangent"}
        "exact": cof(J) n0 from the FFD Jacobian at each vertex.
        "tangent": Section 2.4 of the GPU FFD paper: two tangents T1, T2 with
        T1 x T2 = n0 mapped by forward differences with step ``eps``,
        N = [D(x) - D(x + eps T1)] x [D(x) - D(x + eps T2)].
    rest_normals : (V, 3), optional
        normals of the rest surface (default: ``vertex_normals(deformer.mesh)``).
    eps : float, optional
        finite-difference step of "tangent", world units (default: 1e-4 times the
        lattice box diagonal).
    out : (V, 3) float64 array, optional
        written with the normals and returned (C-contiguous, writable; see
        ``Deformer.deform``'s ``out``).
    """
    # Duck-typed (what is used below), so that this layer does not import the Deformer's.
    if not all(hasattr(deformer, a) for a in ("_d", "_P", "_threads", "lattice", "mesh")):
        raise TypeError(f"deformed_normals: expected a vpffd.Deformer, got {type(deformer).__name__}")
    m = deformer.mesh
    N0 = m._vertex_normals() if rest_normals is None else _arrays.points(
        rest_normals, "deformed_normals: rest_normals", rows=m.n_vertices)
    if method == "exact":
        # The Jacobians in blocks inside the core, never as a (V, 3, 3) array.
        P = deformer._P(control_points)
        out = _arrays.out_array(out, m.n_vertices, "deformed_normals: out", [("control_points", P),
                                                                              ("rest_normals", N0)])
        return deformer._d.deformed_normals(P, N0, deformer._threads, out)
    if method == "tangent":
        lat = deformer.lattice
        if eps is None:
            eps = 1e-4 * float(np.linalg.norm(lat.box_max - lat.box_min))
        eps = float(eps)
        if not (np.isfinite(eps) and eps > 0):
            raise InvalidInputError(f"deformed_normals: eps must be positive, got {eps}")
        P = lat._control(control_points)
        N = _core.deformed_normals_tangent(lat._spec, lat._expand(P), m.vertices, N0, eps)
        if out is None:
            return N
        out = _arrays.out_array(out, m.n_vertices, "deformed_normals: out", [("control_points", P)])
        out[...] = N  # the tangent method has no kernel that writes in place
        return out
    raise InvalidInputError(f"deformed_normals: method must be 'exact' or 'tangent', got {method!r}")


def angles_deg(a, b) -> np.ndarray:
    """(n,) angles in degrees between corresponding rows of two (n, 3) arrays
    (NaN where either row is zero). Uses atan2(|a x b|, a . b), accurate for tiny angles."""
    A = np.asarray(a, dtype=np.float64)
    B = np.asarray(b, dtype=np.float64)
    if A.shape != B.shape or A.ndim != 2 or A.shape[1] != 3:
        raise InvalidInputError(f"angles_deg: expected two (n, 3) arrays of one shape, got {A.shape} and {B.shape}")
    c = np.linalg.norm(np.cross(A, B), axis=1)
    d = np.einsum("ij,ij->i", A, B)
    out = np.degrees(np.arctan2(c, d))
    out[(np.linalg.norm(A, axis=1) == 0) | (np.linalg.norm(B, axis=1) == 0)] = np.nan
    return out
