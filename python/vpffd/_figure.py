"""A standing, pear-like figure built in code (y up, a flat base, a lumpy
surface): the model of the README's comparison picture and of the render
benchmark, where no scanned model can be shipped."""
from __future__ import annotations

import numpy as np

from . import shapes
from .mesh import Mesh


def figure(subdivisions: int = 5) -> Mesh:
    """A closed, y-up pear with a flat base at its bottom (icosphere(subdivisions)
    reshaped: 10 * 4^s + 2 vertices)."""
    m = shapes.icosphere(subdivisions)
    P = m.vertices.copy()
    x, y, z = P[:, 0], P[:, 1], P[:, 2]
    theta = np.arctan2(z, x)
    # narrow neck above, round belly below, a few lumps like a scanned object
    width = 0.62 + 0.30 * np.cos(1.35 * (y + 0.35)) ** 2 - 0.12 * np.clip(y - 0.45, 0, None)
    lumps = 1.0 + 0.045 * np.sin(3 * theta + 2.0 * y) + 0.03 * np.cos(5 * theta - 3.0 * y) * (1 - y * y)
    P[:, 0] = x * width * lumps
    P[:, 2] = z * width * lumps
    P[:, 1] = 1.25 * np.maximum(y, -0.82)  # the flat base it stands on
    return Mesh(P, m.faces)
