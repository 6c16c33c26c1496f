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
