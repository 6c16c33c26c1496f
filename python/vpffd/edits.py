"""Ready-made lattice edits: each returns new control points, same shape as given."""
from __future__ import annotations

import numpy as np

from . import _arrays, _core

_AXES = {"x": 0, "y": 1, "z": 2}


def _axis(axis, name="axis") -> int:
    if axis in _AXES:
        return _AXES[axis]
    if isinstance(axis, (int, np.integer)) and axis in (0, 1, 2):
        return int(axis)
    raise _core.InvalidInputError(f"{name}: expected 'x', 'y', 'z' or 0..2, got {axis!r}")


def _prep(points, center):
    P = np.asarray(points)
    shape = P.shape
    if P.ndim < 2 or shape[-1] != 3:
        raise _core.InvalidInputError(f"control points: expected shape (..., 3), e.g. (nu, nv, nw, 3) or (N, 3), "
                                      f"got {shape}")
    flat = _arrays.points(P.reshape(-1, 3) if P.ndim >= 2 else P, "control points")
    c = 0.5 * (flat.min(axis=0) + flat.max(axis=0)) if center is None else _arrays.vector3(center, "center")
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
