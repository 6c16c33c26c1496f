"""The Blender add-on's bpy-free bookkeeping (blender/vpffd_blender/mapping.py).

Loaded by path, without the add-on package (whose __init__ needs bpy)."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

import vpffd

_PATH = Path(__file__).resolve().parents[2] / "blender" / "vpffd_blender" / "mapping.py"


@pytest.fixture(scope="module")
def mapping():
    spec = importlib.util.spec_from_file_location("vpffd_blender_mapping", _PATH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def blender_rest_grid(shape, lo, hi):
    """Blender's rest points as LatticePoint.co lists them: u fastest, then v, then w."""
    nu, nv, nw = shape
    axes = [np.linspace(lo[a], hi[a], shape[a]) for a in range(3)]
    return np.array([(axes[0][i], axes[1][j], axes[2][k])
                     for k in range(nw) for j in range(nv) for i in range(nu)])


def test_point_order_u_fastest(mapping):
    shape = (3, 4, 5)
    nu, nv, nw = shape
    flat = np.zeros((nu * nv * nw, 3))
    for k in range(nw):
        for j in range(nv):
            for i in range(nu):
                flat[i + nu * (j + nv * k)] = (i, j, k)
    grid = mapping.blender_to_grid(flat, shape)
    assert grid.shape == (3, 4, 5, 3)
    idx = np.stack(np.meshgrid(np.arange(nu), np.arange(nv), np.arange(nw), indexing="ij"), axis=-1)
    assert np.array_equal(grid, idx)
    assert np.array_equal(mapping.grid_to_blender(grid), flat)
    s = mapping.scalars_to_grid(np.arange(nu * nv * nw), shape)
    assert s[2, 1, 3] == 2 + nu * (1 + nv * 3)


def test_wrong_counts_refused(mapping):
    with pytest.raises(ValueError, match="expected 24 points"):
        mapping.blender_to_grid(np.zeros((23, 3)), (2, 3, 4))
    with pytest.raises(ValueError, match=r"\(nu, nv, nw, 3\)"):
        mapping.grid_to_blender(np.zeros((2, 3, 3)))
    with pytest.raises(ValueError, match="expected 24 values"):
        mapping.scalars_to_grid(np.zeros(25), (2, 3, 4))


def test_box_and_flat_lattice(mapping):
    co = blender_rest_grid((3, 2, 4), (-1, -0.5, -1.5), (1, 0.5, 1.5))
    lo, hi = mapping.lattice_box(co)
    assert np.array_equal(lo, [-1, -0.5, -1.5]) and np.array_equal(hi, [1, 0.5, 1.5])
    with pytest.raises(ValueError, match="flat along its local y"):
        mapping.lattice_box(blender_rest_grid((3, 1, 4), (-1, 0, -1), (1, 0, 1)))


def test_degrees_follow_resolution(mapping):
    assert mapping.degrees_for((2, 3, 8), 3) == (1, 2, 3)
    assert mapping.degrees_for((6, 6, 6), 5) == (5, 5, 5)


def test_dragging_a_blender_point_moves_that_control_point(mapping):
    """Degree 1: vpffd's rest net is Blender's rest grid, and moving Blender point p
    moves the FFD image of exactly that grid node by the same offset."""
    shape = (3, 4, 2)
    co = blender_rest_grid(shape, (-0.5, -0.5, -0.5), (0.5, 0.5, 0.5))
    lo, hi = mapping.lattice_box(co)
    lat = vpffd.Lattice(lo, hi, shape=shape, degree=mapping.degrees_for(shape, 1))
    # Linear B-splines: Greville abscissae are the knots, an evenly spaced grid (to rounding).
    assert np.allclose(mapping.grid_to_blender(lat.rest_points), co, atol=1e-15, rtol=0)
    i, j, k = 2, 1, 1
    p = i + shape[0] * (j + shape[1] * k)
    moved = co.copy()
    d = np.array([0.05, -0.1, 0.2])
    moved[p] += d
    P = mapping.blender_to_grid(moved, shape)
    out = lat.deform_points(co[[p, 0]], control_points=P)
    # Basis functions of degree 1 are 1 at their own node and 0 at the others: exact
    # up to the rounding of the affine box map (a few ulps of a unit box).
    assert np.allclose(out[0], co[p] + d, atol=1e-14, rtol=0)
    assert np.allclose(out[1], co[0], atol=1e-14, rtol=0)


def test_rebase_keeps_offsets(mapping):
    shape = (6, 5, 7)
    co = blender_rest_grid(shape, (-0.5,) * 3, (0.5,) * 3)
    lat = vpffd.Lattice(*mapping.lattice_box(co), shape=shape, degree=3)
    shown = mapping.blender_to_grid(co, shape).copy()
    shown[1, 2, 3] += (0.1, 0.0, -0.05)
    P = mapping.rebased_points(shown, mapping.blender_to_grid(co, shape), lat.rest_points)
    delta = P - lat.rest_points
    assert np.allclose(delta[1, 2, 3], (0.1, 0.0, -0.05), atol=1e-15)
    delta[1, 2, 3] = 0
    assert np.abs(delta).max() <= 1e-16 * 4
    # Cubic clamped B-splines with more than 4 points: the rest net is not Blender's uniform
    # grid (which is why the add-on rebinds; with 4 points it is a Bezier net, uniform).
    assert np.abs(lat.rest_points - mapping.blender_to_grid(co, shape)).max() > 0.05


def test_group_weights(mapping):
    w, fixed = mapping.group_weights([0.0, 0.5, 0.9, 1.0, 1.2, -0.3])
    assert np.allclose(w[:3], [1.0, 2.0, 10.0])
    assert fixed.tolist() == [False, False, False, True, True, False]
    assert w[5] == 1.0
    w, fixed = mapping.group_weights(np.zeros((2, 2, 2)))
    assert fixed is None and w.shape == (2, 2, 2)
    with pytest.raises(ValueError, match="NaN"):
        mapping.group_weights([0.0, np.nan])


def test_affine_and_outside(mapping):
    M = np.eye(4)
    M[:3, :3] = [[0, -2, 0], [2, 0, 0], [0, 0, 1]]
    M[:3, 3] = [1, 2, 3]
    assert np.allclose(mapping.affine(M, [[1, 0, 0], [0, 1, 0]]), [[1, 4, 3], [-1, 2, 3]])
    assert mapping.outside_count([[0, 0, 0], [1, 0, 0], [1.0000001, 0, 0]], (-1, -1, -1), (1, 1, 1)) == 1


@pytest.fixture(scope="module")
def rounding():
    spec = importlib.util.spec_from_file_location("vpffd_blender_rounding", _PATH.parent / "rounding.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_volume_gradient_is_the_derivative(rounding):
    m = vpffd.shapes.icosphere(2)
    V, F = m.vertices * [1.3, 0.8, 1.1] + 0.4, m.faces
    g = rounding.volume_gradient(V, F)
    assert rounding.volume(V, F) == pytest.approx(m.volume * 1.3 * 0.8 * 1.1, rel=1e-14)
    h = 1e-6
    for v, c in ((0, 0), (17, 1), (100, 2)):
        W = V.copy()
        W[v, c] += h
        # V is linear in each single coordinate (a coordinate enters each face term once):
        # the difference quotient is exact up to cancellation, ~1e-16 * V / h.
        assert (rounding.volume(W, F) - rounding.volume(V, F)) / h == pytest.approx(g[v, c], abs=1e-8)


def test_float32_key_keeps_the_volume_to_double_precision(rounding):
    """A squashed sphere, corrected by vpffd in float64, written as a float32 shape key:
    Blender's evaluation (basis + (key - basis) in float32) of the chosen key has the rest
    volume to 1e-13, where rounding to nearest leaves ~1e-8."""
    m = vpffd.shapes.icosphere(5)  # 10,242 vertices
    basis = (m.vertices * [1.5, 1.2, 1.0] + [0.3, -0.2, 0.1]).astype(np.float32)
    rest = basis.astype(np.float64)
    lat = vpffd.Lattice.around(rest, shape=(5, 5, 5))
    lat.control_points = vpffd.squash(lat.control_points, 0.55)
    r = vpffd.Deformer((rest, m.faces), lat).deform()
    target = rounding.volume(rest, m.faces)
    nearest = abs(rounding.volume(rounding.evaluated(r.vertices.astype(np.float32), basis), m.faces) - target)
    key = rounding.volume_exact_key(r.vertices, basis, m.faces, target)
    assert key.dtype == np.float32 and key.shape == r.vertices.shape
    err = abs(rounding.volume(rounding.evaluated(key, basis), m.faces) - target)
    # What is left: the float64 pairwise sums of 20k face terms (~1e-15 of the volume)
    # and the smallest one-ulp steps; 1e-13 leaves a wide margin over both.
    assert err <= 1e-13 * target
    assert err <= nearest
    # every coordinate is the nearest float32 or its neighbour
    near = r.vertices.astype(np.float32)
    ulps = np.abs(key.astype(np.float64) - near) / np.spacing(np.abs(near))
    assert ulps.max() <= 1.0
