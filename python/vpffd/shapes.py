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
