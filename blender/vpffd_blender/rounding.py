"""Float32 shape keys whose evaluated mesh keeps the volume to double precision (no bpy).

Blender stores positions in float32 and evaluates a relative shape key of value 1
as ``basis + (key - basis)``, each operation rounded to float32. Writing vpffd's
double-precision vertices rounded to nearest moves the enclosed volume by up to
~1e-7 relative (each coordinate moves by up to half a float32 ulp). Among the
float32 keys next to the exact vertices there are ones whose evaluated mesh has the
exact volume to ~1e-13: the volume changes by g . d when a coordinate moves by d
(g = dV/dx, a third of the area-weighted normal there), and the 3V one-ulp steps
have sizes spread over many orders of magnitude, so a greedy choice (largest step
that does not overshoot, then smaller ones) cancels the rounding residual. Each
coordinate moves by at most one ulp from round-to-nearest.
"""
from __future__ import annotations

import numpy as np

_MAX_PASSES = 8
_WINDOW = 1024


def evaluated(key, basis) -> np.ndarray:
    """What Blender shows for a relative shape key of value 1: fl32(basis + fl32(key - basis))."""
    key = np.asarray(key, dtype=np.float32)
    basis = np.asarray(basis, dtype=np.float32)
    return basis + (key - basis)


def _corners(V, F):
    V = np.asarray(V, dtype=np.float64)
    return V[F[:, 0]].T, V[F[:, 1]].T, V[F[:, 2]].T


def _cross(p, q):
    # Component-wise: np.cross on (F, 3) rows costs several times more.
    return (p[1] * q[2] - p[2] * q[1], p[2] * q[0] - p[0] * q[2], p[0] * q[1] - p[1] * q[0])


def volume(V, F) -> float:
    """Enclosed volume of triangles F over vertices V, summed in float64."""
    a, b, c = _corners(V, F)
    x = _cross(b, c)
    return float((a[0] * x[0] + a[1] * x[1] + a[2] * x[2]).sum() / 6.0)


def volume_gradient(V, F) -> np.ndarray:
    """(n, 3) dV/dx at every vertex: (1/6) the sum over its faces of the cross product
    of the other two corners (origin-independent on a closed mesh)."""
    a, b, c = _corners(V, F)
    n = len(V)
    parts = (_cross(b, c), _cross(c, a), _cross(a, b))
    g = np.empty((n, 3))
    for k in range(3):
        g[:, k] = sum(np.bincount(F[:, j], weights=parts[j][k], minlength=n) for j in range(3))
    return g / 6.0


def volume_exact_key(vertices, basis, faces, target_volume) -> np.ndarray:
    """(n, 3) float32 shape key near ``vertices`` whose evaluated mesh (``evaluated``)
    has volume ``target_volume`` as closely as float32 allows.

    vertices : (n, 3) float64, the exact positions (mesh-local)
    basis : (n, 3) float32, the reference key the shape key is relative to
    faces : (F, 3) int, a closed triangulation
    """
    Y = np.asarray(vertices, dtype=np.float64)
    basis = np.asarray(basis, dtype=np.float32)
    F = np.asarray(faces, dtype=np.int64)
    key = Y.astype(np.float32)
    g = volume_gradient(Y, F).ravel()
    R = volume(evaluated(key, basis), F) - target_volume
    used = np.zeros(key.size, dtype=bool)  # each coordinate moves at most once: one ulp from nearest
    for _ in range(_MAX_PASSES):
        if R == 0.0:
            break
        E = evaluated(key, basis).ravel()
        # Move each coordinate one ulp in the direction that lowers |R|.
        toward = np.where(g * -np.sign(R) > 0, np.inf, -np.inf).astype(np.float32)
        k_flat = key.ravel()
        step_key = np.nextafter(k_flat, toward)
        d = evaluated(step_key, basis.ravel()).astype(np.float64) - E.astype(np.float64)
        gain = np.where(used, 0.0, np.abs(g * d))  # each step lowers |R| by gain (to first order)
        order = np.argsort(-gain, kind="stable")
        gain_sorted = gain[order]
        left = abs(R)
        chosen = []
        i = int(np.searchsorted(-gain_sorted, -left, side="left"))  # skip steps larger than what is left
        while i < len(order) and left > 0 and gain_sorted[i] > 0:
            take = np.cumsum(gain_sorted[i:i + _WINDOW])  # a window: the prefix taken is short
            n = int(np.searchsorted(take, left, side="right"))
            if n:
                chosen.append(order[i:i + n])
                left -= take[n - 1]
            i += n
            i += int(np.searchsorted(-gain_sorted[i:], -left, side="left"))
        k_flat = k_flat.copy()
        if chosen and left < 0.5 * abs(R):
            idx = np.concatenate(chosen)
            k_flat[idx] = step_key[idx]
        else:
            # Single steps overshoot (or only nibble): one coordinate one ulp in the helpful direction
            # and another one ulp the other way, whose gains differ by about |R|.
            hurt = np.abs(g * (evaluated(np.nextafter(k_flat, -toward), basis.ravel()).astype(np.float64)
                               - E.astype(np.float64)))
            i, j = _best_pair(gain, np.where(used, np.inf, hurt), abs(R))
            if i is None:
                break
            k_flat[i] = step_key[i]
            k_flat[j] = np.nextafter(k_flat[j], -toward[j])
            idx = np.array([i, j])
        R_new = volume(evaluated(k_flat.reshape(-1, 3), basis), F) - target_volume
        if not abs(R_new) < abs(R):  # second-order effects won: keep the better key
            break
        key, R = k_flat.reshape(-1, 3), R_new
        used[idx] = True
    return key


def _best_pair(help_gain, hurt_gain, left):
    """(i, j): moving coordinate i the helpful way and j (!= i) the other way changes the
    residual by help_gain[i] - hurt_gain[j]; the pair bringing it closest to ``left``,
    or (None, None) when no pair lowers it."""
    order = np.argsort(hurt_gain, kind="stable")
    hurt = hurt_gain[order]
    want = help_gain - left  # hurt_gain[j] close to this leaves nothing over
    pos = np.searchsorted(hurt, want)
    best, bi, bj = left, None, None
    for cand in (np.clip(pos - 1, 0, len(hurt) - 1), np.clip(pos, 0, len(hurt) - 1)):
        miss = np.abs(left - (help_gain - hurt[cand]))
        miss[order[cand] == np.arange(len(help_gain))] = np.inf
        i = int(np.argmin(miss))
        if miss[i] < best:
            best, bi, bj = miss[i], i, int(order[cand[i]])
    return bi, bj
