"""Ready-made lattice edits: each returns new control points, same shape as given."""
from __future__ import annotations

import numpy as np

from . import _arrays, _core

def _axis(axis, name="axis") -> int:
    return _arrays.axis(axis, name)


def _prep(points, center):
    P = np.asarray(points)
    shape = P.shape
    if P.ndim < 2 or shape[-1] != 3:
        raise _core.InvalidInputError(f"control points: expected shape (..., 3), e.g. (nu, nv, nw, 3) or (N, 3), "
                                      f"got {shape}")
    flat = _arrays.points(P.reshape(-1, 3) if P.ndim >= 2 else P, "control points")
    if center is None:
        lo, hi = _arrays.bounds(flat)
        c = 0.5 * (lo + hi)
    else:
        c = _arrays.vector3(center, "center")
    return flat, shape, c


def twist(points, angle: float, axis="z", center=None) -> np.ndarray:
    """Twists about ``axis`` through ``center`` (default: the points' box centre):
    the lowest points stay, the highest turn by ``angle`` degrees."""
    P, shape, c = _prep(points, center)
    return _core.twist(P, np.radians(angle), _axis(axis), c).reshape(shape)


def bend(points, angle: float, axis="z", toward="x", center=None) -> np.ndarray:
    """Bends the extent along ``axis`` into an arc of ``angle`` degrees curving
    towards +``toward``."""
    P, shape, c = _prep(points, center)
    return _core.bend(P, np.radians(angle), _axis(axis), _axis(toward, "toward"), c).reshape(shape)


def taper(points, factor: float, axis="z", center=None) -> np.ndarray:
    """Scales across ``axis`` from 1 at the bottom to ``factor`` at the top."""
    P, shape, c = _prep(points, center)
    return _core.taper(P, float(factor), _axis(axis), c).reshape(shape)


def scale(points, factors, center=None) -> np.ndarray:
    """Scales about ``center`` by ``factors`` (one number or three)."""
    P, shape, c = _prep(points, center)
    f = np.broadcast_to(np.asarray(factors, dtype=np.float64), (3,)).copy()
    return _core.scale(P, f, c).reshape(shape)


def squash(points, factor: float, axis="z", center=None, keep_volume_guess: bool = False) -> np.ndarray:
    """Scales along ``axis`` by ``factor`` about ``center``. With
    ``keep_volume_guess`` the other two axes grow by 1/sqrt(factor) (the naive
    volume-keeping stretch, for comparison with the exact correction)."""
    a = _axis(axis)
    f = np.ones(3)
    f[a] = factor
    if keep_volume_guess:
        f[[i for i in range(3) if i != a]] = 1.0 / np.sqrt(factor)
    return scale(points, f, center)


# --- lattice shapes ---------------------------------------------------------------
# These build control points from a lattice's structure (not from given points): the
# lattice's box becomes a ring, a Moebius band or a terrain-following slab.

def _lattice(lattice, who):
    from .lattice import Lattice
    if not isinstance(lattice, Lattice):
        raise TypeError(f"{who}: expected a vpffd.Lattice, got {type(lattice).__name__}")
    return lattice


def _need_seam(lattice, a: int, seam: str, who: str) -> None:
    have = lattice.seams.get("xyz"[a])
    if have != seam:
        now = "is not periodic" if have is None else f"has the {have!r} seam"
        raise _core.InvalidInputError(
            f"{who}: needs a lattice periodic along {'xyz'[a]} with seam={seam!r}, but {'xyz'[a]} {now}; "
            f"build it as vpffd.Lattice(..., periodic={'xyz'[a]!r}, seam={seam!r})")


def _positive(v, name, who) -> float:
    return _arrays.positive(v, name, who)


def ring(lattice, radius=None, axis="x", around="z") -> np.ndarray:
    """Control points that bend a periodic lattice around a circle: the box's
    ``axis`` becomes the circle, in the plane normal to ``around``, so that the
    deformation is a closed ring with no seam.

    The lattice must be periodic along ``axis`` with ``seam="closed"`` (the tied
    copies of the first slices then land on them: the net closes). The third axis
    becomes the radial direction and ``around`` stays as it is, so the cross-section
    keeps its size; the ring's centre is the box centre.

    Parameters
    ----------
    lattice : vpffd.Lattice
    radius : float, optional
        radius of the circle the box's centre line follows, world units; default
        the one that keeps that line's length, extent_axis / (2 pi). Must exceed half
        the box's radial extent (else the inner side would turn inside out).
    axis, around : {"x", "y", "z"}, different

    Returns
    -------
    (nu, nv, nw, 3) float64 distinct control points (``lattice.shape``).
    """
    lat = _lattice(lattice, "ring")
    a, c = _axis(axis), _axis(around, "around")
    if a == c:
        raise _core.InvalidInputError(f"ring: axis and around must differ, both are {'xyz'[a]!r}")
    _need_seam(lat, a, "closed", "ring")
    r_ax = 3 - a - c  # the radial axis
    lo, hi, ctr = lat.box_min, lat.box_max, lat.center
    R = (hi[a] - lo[a]) / (2 * np.pi) if radius is None else _positive(radius, "radius", "ring")
    half = 0.5 * (hi[r_ax] - lo[r_ax])
    if not R > half:
        raise _core.InvalidInputError(f"ring: radius {R:g} must exceed half the box's extent along "
                                      f"{'xyz'[r_ax]} ({half:g}), or the inner side folds")
    X = np.asarray(lat.rest_points, dtype=np.float64)
    theta = 2 * np.pi * (X[..., a] - lo[a]) / (hi[a] - lo[a])
    r = R + (X[..., r_ax] - ctr[r_ax])
    out = np.empty_like(X)
    # (axis, radial) span the circle's plane, in that order: +axis at theta = 0.
    # Turning from +axis towards -radial keeps the orientation (det J > 0): the other
    # way round the box's (axis, radial) pair would come out swapped, turning meshes inside out.
    out[..., a] = ctr[a] + r * np.cos(theta)
    out[..., r_ax] = ctr[r_ax] - r * np.sin(theta)
    out[..., c] = X[..., c]
    return out


def mobius(lattice, radius, width=None, height=None) -> np.ndarray:
    """Control points of a Moebius band (the motion spec's formula): with s in
    [0, 1) along the twisted axis, v, w in [-1/2, 1/2] across the other two (in
    order), e_r(s) = (cos 2 pi s, sin 2 pi s, 0), e_z = (0, 0, 1),
    b(s) = cos(pi s) e_r + sin(pi s) e_z, n(s) = -sin(pi s) e_r + cos(pi s) e_z:

        P = C + radius e_r(s) - v width b(s) + w height n(s),

    C the box centre. (The spec writes +v; with it the map would mirror the box,
    det J < 0, and turn meshes inside out; -v keeps the orientation.) The band turns half a turn about its centre line in one
    revolution. The lattice must be periodic along one axis with ``seam="twist"``:
    s = 1 + s' is then the point at s' with v, w mirrored, which is what the
    formula gives (b and n change sign), so the band closes without a seam.

    Parameters
    ----------
    lattice : vpffd.Lattice
        periodic along exactly one axis with seam "twist".
    radius : float
        radius of the centre line, world units (> width / 2).
    width, height : float, optional
        size of the cross-section, world units; default the box's extents along
        the two other axes (so a straight band would keep its cross-section).

    Returns
    -------
    (nu, nv, nw, 3) float64 distinct control points.
    """
    lat = _lattice(lattice, "mobius")
    twisted = [k for k, v in lat.seams.items() if v == "twist"]
    if len(twisted) != 1:
        raise _core.InvalidInputError(
            f"mobius: needs a lattice periodic along one axis with seam='twist' (got seams {lat.seams or 'none'}); "
            f"build it as vpffd.Lattice(..., periodic='x', seam='twist')")
    a = "xyz".index(twisted[0])
    b, c = [k for k in range(3) if k != a]
    lo, hi = lat.box_min, lat.box_max
    R = _positive(radius, "radius", "mobius")
    W = hi[b] - lo[b] if width is None else _positive(width, "width", "mobius")
    H = hi[c] - lo[c] if height is None else _positive(height, "height", "mobius")
    if not R > 0.5 * W:
        raise _core.InvalidInputError(f"mobius: radius {R:g} must exceed half the width ({0.5 * W:g})")
    X = np.asarray(lat.rest_points, dtype=np.float64)
    s = ((X[..., a] - lo[a]) / (hi[a] - lo[a]))[..., None]
    v = ((X[..., b] - lo[b]) / (hi[b] - lo[b]) - 0.5)[..., None]
    w = ((X[..., c] - lo[c]) / (hi[c] - lo[c]) - 0.5)[..., None]
    zero = np.zeros_like(s)
    e_r = np.concatenate([np.cos(2 * np.pi * s), np.sin(2 * np.pi * s), zero], axis=-1)
    e_z = np.concatenate([zero, zero, np.ones_like(s)], axis=-1)
    bn = np.cos(np.pi * s) * e_r + np.sin(np.pi * s) * e_z
    nn = -np.sin(np.pi * s) * e_r + np.cos(np.pi * s) * e_z
    return lat.center + R * e_r - v * W * bn + w * H * nn


def terrain(lattice, height) -> np.ndarray:
    """Control points that lay the lattice over a height field: each column of
    control points is lifted by the height under it,
    P_ijk = (x_i, y_j, z_k + h(x_i, y_j)) (z is up), so an object moved through
    the rest box (``animate.PathOffset``) follows the terrain.

    Parameters
    ----------
    lattice : vpffd.Lattice
        any; with a periodic x or y, h should be periodic too, or the net jumps at
        the seam by the difference.
    height : callable or array
        ``h(x, y) -> z offset`` taking and returning arrays of shape (nu, nv)
        (world units), evaluated at the rest control points; or an (nu, nv) array
        of heights at them.

    Returns
    -------
    (nu, nv, nw, 3) float64 distinct control points.
    """
    lat = _lattice(lattice, "terrain")
    X = np.array(lat.rest_points, dtype=np.float64)
    nu, nv = lat.shape[0], lat.shape[1]
    if callable(height):
        h = np.asarray(height(X[:, :, 0, 0], X[:, :, 0, 1]), dtype=np.float64)
        if h.shape == ():
            h = np.full((nu, nv), float(h))
        what = "terrain: height(x, y)"
    else:
        try:
            h = np.asarray(height, dtype=np.float64)
        except (TypeError, ValueError):
            raise _core.InvalidInputError(f"terrain: height must be a callable h(x, y) or an (nu, nv) array of "
                                          f"numbers, got {type(height).__name__}") from None
        what = "terrain: height"
    if h.shape != (nu, nv):
        raise _core.InvalidInputError(f"{what} has shape {h.shape}; expected {(nu, nv)}, one height per "
                                      f"control point column")
    if not np.isfinite(h).all():
        raise _core.InvalidInputError(f"{what} contains NaN or Inf")
    X[..., 2] += h[:, :, None]
    return X
