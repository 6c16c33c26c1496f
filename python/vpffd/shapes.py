"""Closed meshes generated in code (no files needed)."""
from __future__ import annotations

from . import _core
from .mesh import Mesh


def icosphere(subdivisions: int = 4, radius: float = 1.0) -> Mesh:
    """Icosahedron subdivided ``subdivisions`` times on a sphere: 10*4^s+2 vertices
    (s=4: 2,562, the paper's Sphere)."""
    return Mesh(*_core.icosphere(subdivisions, radius))


def box(n: int = 32, size: float = 1.0) -> Mesh:
    """Surface of a cube of edge ``size`` centred at the origin, each side split
    into n x n squares: 6n^2+2 vertices (n=32: 6,146, the paper's twisting cube)."""
    return Mesh(*_core.box_mesh(n, size))


def bumpy_sphere(subdivisions: int = 5, radius: float = 1.0, amplitude: float = 0.04, frequency: float = 9.0,
                 stretch=(1.0, 1.0, 1.0)) -> Mesh:
    """A detailed closed mesh for multiresolution tests and demos: an icosphere
    whose radius is modulated by ``1 + amplitude * sin(f x) sin(f y) sin(f z)`` (a
    regular pattern of bumps and dents; f = ``frequency`` on the unit sphere),
    then scaled per axis by ``stretch`` (e.g. (2, 1, 1) for an elongated body to
    bend or twist). 10*4^s+2 vertices."""
    import numpy as np

    if not (np.isfinite(amplitude) and 0 <= amplitude < 0.5):
        raise _core.InvalidInputError(f"bumpy_sphere: amplitude must be in [0, 0.5), got {amplitude}")
    s = np.asarray(stretch, dtype=np.float64)
    if s.shape != (3,) or not (np.isfinite(s).all() and (s > 0).all()):
        raise _core.InvalidInputError(f"bumpy_sphere: stretch must be three positive numbers, got {stretch!r}")
    m = icosphere(subdivisions, 1.0)
    U = m.vertices / np.linalg.norm(m.vertices, axis=1, keepdims=True)
    f = float(frequency)
    r = radius * (1.0 + amplitude * np.sin(f * U[:, 0]) * np.sin(f * U[:, 1]) * np.sin(f * U[:, 2]))
    return Mesh(U * r[:, None] * s, m.faces)


def _count(v, name: str, lo: int, who: str) -> int:
    import numpy as np

    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
        raise _core.InvalidInputError(f"{who}: {name} must be an integer >= {lo}, got {v!r}")
    if v > 1 << 14:
        raise _core.InvalidInputError(f"{who}: {name} = {v} is more than {1 << 14}")
    return int(v)


def uv_sphere(rings: int = 32, segments: int = 64, radius: float = 1.0) -> Mesh:
    """Latitude-longitude sphere: ``rings`` bands from pole to pole, ``segments``
    around; (rings - 1) * segments + 2 vertices, 2 * (rings - 1) * segments
    triangles, outward-facing. Unlike ``icosphere`` any vertex count of that form
    can be hit (the benchmarks use it to match a paper's counts)."""
    import numpy as np

    rings = _count(rings, "rings", 2, "uv_sphere")
    segments = _count(segments, "segments", 3, "uv_sphere")
    if not (np.isfinite(radius) and radius > 0):
        raise _core.InvalidInputError(f"uv_sphere: radius must be positive and finite, got {radius!r}")
    theta = np.pi * np.arange(1, rings) / rings                 # polar angle of the inner rings
    phi = 2.0 * np.pi * np.arange(segments) / segments
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    ring = np.stack([st * np.cos(phi), st * np.sin(phi), np.broadcast_to(ct, (rings - 1, segments))], axis=-1)
    V = np.concatenate([[[0.0, 0.0, 1.0]], ring.reshape(-1, 3), [[0.0, 0.0, -1.0]]]) * radius
    north, south = 0, len(V) - 1
    idx = 1 + np.arange((rings - 1) * segments).reshape(rings - 1, segments)
    nxt = np.roll(idx, -1, axis=1)
    # Counter-clockwise seen from outside: z decreases down the rings, phi increases around.
    cap_n = np.stack([np.full(segments, north), idx[0], nxt[0]], axis=1)
    cap_s = np.stack([np.full(segments, south), nxt[-1], idx[-1]], axis=1)
    a, b, c, d = idx[:-1], nxt[:-1], idx[1:], nxt[1:]
    quads = np.concatenate([np.stack([a, c, d], -1).reshape(-1, 3), np.stack([a, d, b], -1).reshape(-1, 3)])
    F = np.concatenate([cap_n, quads, cap_s]).astype(np.int32)
    return Mesh(V, F)


def fish(rings: int = 24, segments: int = 48, length: float = 1.0) -> Mesh:
    """A closed creature for the motion demos (the paper's whales): a body along
    +x of the given ``length`` with a tapered, vertically flared tail fin, made
    by scaling a ``uv_sphere(rings, segments)`` along y and z by positive
    functions of x (so it stays a closed, non-self-intersecting surface).
    Head at +x, (rings - 1) * segments + 2 vertices."""
    import numpy as np

    if not (np.isfinite(length) and length > 0):
        raise _core.InvalidInputError(f"fish: length must be positive and finite, got {length!r}")
    m = uv_sphere(rings, segments, 1.0)
    # Lay the sphere's pole axis along x so the rings are cross-sections of the body.
    U = m.vertices[:, [2, 0, 1]]
    x = U[:, 0]
    rr = np.sqrt(np.maximum(0.0, 1.0 - x * x))                   # the sphere's cross-section radius
    s = np.clip((-0.35 - x) / 0.65, 0.0, 1.0)                    # 0 on the body, 1 at the tail tip
    with np.errstate(invalid="ignore", divide="ignore"):
        c = np.where(rr > 0, U[:, 1] / rr, 0.0), np.where(rr > 0, U[:, 2] / rr, 0.0)
    width = 0.26 * rr * (1.0 + 0.2 * x) * (1.0 - 0.8 * s)         # the tail thins sideways ...
    height = 0.32 * rr * (1.0 + 0.2 * x) + 0.6 * s * s * rr ** 0.25  # ... and flares into a fin
    V = np.stack([x, c[0] * width, c[1] * height], axis=1) * (0.5 * length)
    # The axis permutation (x, y, z) <- (z, x, y) is even: orientation is kept.
    return Mesh(V, m.faces)
