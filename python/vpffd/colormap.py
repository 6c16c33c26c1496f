"""Colour maps: scalars per vertex to RGB in [0, 1]."""
from __future__ import annotations

import math

import numpy as np

from . import _core

InvalidInputError = _core.InvalidInputError

# Anchors of two colour maps (sRGB in [0, 1]), interpolated linearly.
_VIRIDIS = np.array([[0.267, 0.005, 0.329], [0.283, 0.141, 0.458], [0.254, 0.265, 0.530], [0.207, 0.372, 0.553],
                     [0.164, 0.471, 0.558], [0.128, 0.567, 0.551], [0.135, 0.659, 0.518], [0.267, 0.749, 0.441],
                     [0.478, 0.821, 0.318], [0.741, 0.873, 0.150], [0.993, 0.906, 0.144]])
_COOLWARM = np.array([[0.230, 0.299, 0.754], [0.400, 0.533, 0.934], [0.602, 0.731, 0.999], [0.788, 0.845, 0.939],
                      [0.867, 0.867, 0.867], [0.957, 0.770, 0.679], [0.968, 0.608, 0.480], [0.887, 0.392, 0.310],
                      [0.706, 0.016, 0.150]])
COLORMAPS = {"viridis": _VIRIDIS, "coolwarm": _COOLWARM}


def colormap(values, cmap=None, vmin=None, vmax=None) -> np.ndarray:
    """(n, 3) float colours of (n,) scalars.

    Default: "coolwarm" centred on 0 (symmetric range) when the values have both
    signs, as a local volume change has; else "viridis" over [min, max]."""
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    if not np.isfinite(v).all():
        raise InvalidInputError("colormap: values contain NaN or Inf")
    if v.size == 0:
        return np.zeros((0, 3))
    for nm, x in (("vmin", vmin), ("vmax", vmax)):
        if x is not None and not math.isfinite(float(x)):
            raise InvalidInputError(f"colormap: {nm} must be a finite number, got {x!r}")
    if vmin is not None and vmax is not None and float(vmin) > float(vmax):
        raise InvalidInputError(f"colormap: vmin {vmin!r} is above vmax {vmax!r}")
    signed = v.min() < 0 < v.max()
    if cmap is None:
        cmap = "coolwarm" if signed else "viridis"
    if cmap not in COLORMAPS:
        raise InvalidInputError(f"colormap: unknown colour map {cmap!r}; known: {', '.join(COLORMAPS)}")
    if vmin is None and vmax is None and signed and cmap == "coolwarm":
        a = float(np.abs(v).max())
        vmin, vmax = -a, a
    lo = float(v.min()) if vmin is None else float(vmin)
    hi = float(v.max()) if vmax is None else float(vmax)
    t = np.zeros_like(v) if not hi > lo else np.clip((v - lo) / (hi - lo), 0.0, 1.0)
    table = COLORMAPS[cmap]
    s = t * (len(table) - 1)
    i = np.minimum(s.astype(int), len(table) - 2)
    w = (s - i)[:, None]
    return (1 - w) * table[i] + w * table[i + 1]


# Colour of a fold (det J <= 0: the deformation turned the volume inside out
# there): a green outside the blue-white-red range of the diverging map.
FOLD_COLOR = np.array([0.10, 0.72, 0.20])


def volume_change_limit(detj, floor: float = 1.05) -> float:
    """The saturating ratio r >= ``floor`` of ``volume_change_colors`` that covers
    95 % of the positive det J values (r and 1/r are the map's ends): the few
    extreme values next to a fold saturate rather than wash out the rest."""
    d = np.asarray(detj, dtype=np.float64).reshape(-1)
    d = d[np.isfinite(d) & (d > 0)]
    if d.size == 0:
        return float(floor)
    return float(max(floor, math.exp(np.quantile(np.abs(np.log(d)), 0.95))))


def volume_change_colors(detj, limit: float) -> np.ndarray:
    """(V, 3) colours of local volume changes det J (V,): the "coolwarm" map on a
    log scale centred at 1 (det J = 1 neutral grey, 1/``limit`` and below full
    blue: compressed, ``limit`` and above full red: expanded); det J <= 0, a
    fold, in ``FOLD_COLOR``."""
    d = np.asarray(detj, dtype=np.float64).reshape(-1)
    if not np.isfinite(d).all():
        raise InvalidInputError("volume_change_colors: det J contains NaN or Inf")
    limit = float(limit)
    if not (math.isfinite(limit) and limit > 1):
        raise InvalidInputError(f"volume_change_colors: limit must be a finite number > 1, got {limit!r}")
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.log(np.where(d > 0, d, 1.0)) / math.log(limit)
    out = colormap(np.clip(t, -1.0, 1.0), "coolwarm", -1.0, 1.0)
    out[d <= 0] = FOLD_COLOR
    return out
