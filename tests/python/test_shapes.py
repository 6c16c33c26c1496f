"""Meshes generated in code: closed, outward-facing, the vertex counts their docstrings give."""
import numpy as np
import pytest

import vpffd
from vpffd import shapes


@pytest.mark.parametrize("rings,segments", [(2, 3), (5, 7), (32, 64), (218, 130)])
def test_uv_sphere_counts_closed_outward(rings, segments):
    m = shapes.uv_sphere(rings, segments, radius=2.0)
    assert m.n_vertices == (rings - 1) * segments + 2
    assert m.n_faces == 2 * (rings - 1) * segments
    assert m.is_closed
    np.testing.assert_allclose(np.linalg.norm(m.vertices, axis=1), 2.0, rtol=1e-15)
    # An inscribed polyhedron: positive, below the ball's volume, approaching it as it refines.
    v = m.volume
    assert 0 < v < 4 / 3 * np.pi * 8


def test_uv_sphere_volume_converges():
    # The inscribed polyhedron's deficit is O(h^2): quadrupling the resolution cuts it ~16x.
    ball = 4 / 3 * np.pi
    e1 = ball - shapes.uv_sphere(16, 32).volume
    e2 = ball - shapes.uv_sphere(64, 128).volume
    assert 0 < e2 < e1 / 10


def test_uv_sphere_hits_the_papers_whale_count():
    assert shapes.uv_sphere(218, 130).n_vertices == 28_212


def test_fish_is_a_closed_body_along_x():
    f = shapes.fish(24, 48, length=2.0)
    assert f.is_closed and f.volume > 0
    lo, hi = f.bounds
    np.testing.assert_allclose([lo[0], hi[0]], [-1.0, 1.0], rtol=0, atol=1e-12)
    # Longer than it is high, higher (the fin) than it is wide.
    assert hi[0] - lo[0] > hi[2] - lo[2] > hi[1] - lo[1]
    # The tail fin: near the tail the body is taller than it is wide.
    tail = f.vertices[f.vertices[:, 0] < -0.7]
    assert np.ptp(tail[:, 2]) > 2 * np.ptp(tail[:, 1])


@pytest.mark.parametrize("call", [
    lambda: shapes.uv_sphere(1, 8), lambda: shapes.uv_sphere(4, 2), lambda: shapes.uv_sphere(4.5, 8),
    lambda: shapes.uv_sphere(True, 8), lambda: shapes.uv_sphere(4, 8, radius=0.0),
    lambda: shapes.uv_sphere(4, 8, radius=float("nan")), lambda: shapes.uv_sphere(100000, 8),
    lambda: shapes.fish(length=-1.0),
])
def test_bad_arguments_are_refused(call):
    with pytest.raises(vpffd.InvalidInputError):
        call()
