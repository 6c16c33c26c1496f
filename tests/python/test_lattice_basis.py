"""B-spline basis, lattices, knots and the plain FFD through the Python API."""
import numpy as np
import pytest
import scipy.sparse as sp

import vpffd
from vpffd import InvalidInputError



def test_basis_partition_of_unity_and_fast_form():
    for d in range(1, 6):
        t = vpffd._core.clamped_uniform_knots(d + 5, d)
        u = np.linspace(0, 1, 301)
        B = vpffd._core.basis_functions(t, d, u)
        np.testing.assert_allclose(B.sum(axis=1), 1.0, atol=1e-14)
        assert (B >= -1e-15).all()
        np.testing.assert_allclose(vpffd._core.basis_functions_fast(t, d, u), B, atol=1e-13)
        um = np.linspace(0.0013, 0.9987, 97)  # off the knots, where degree-1 derivatives jump
        dB = vpffd._core.basis_functions(t, d, um, True)
        h = 1e-6
        fd = (vpffd._core.basis_functions(t, d, um + h) - vpffd._core.basis_functions(t, d, um - h)) / (2 * h)
        np.testing.assert_allclose(dB, fd, atol=2e-5)


def test_volume_of_cube_and_icosphere():
    cube = vpffd.shapes.box(3, size=2.0)
    assert cube.volume == pytest.approx(8.0, rel=1e-14)
    assert vpffd.shapes.icosphere(4).volume == pytest.approx(4.17973892, rel=1e-8)
    # An icosphere of 6 subdivisions is within 0.03 % of the ball.
    assert vpffd.shapes.icosphere(6).volume == pytest.approx(4 / 3 * np.pi, rel=3e-4)
    assert vpffd.shapes.icosphere(4).n_vertices == 2562
    assert vpffd.shapes.box(32).n_vertices == 6146


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
def test_identity_lattice(sphere, degree):
    lat = vpffd.Lattice.around(sphere, shape=(degree + 2, degree + 3, degree + 4), degree=degree)
    d = vpffd.Deformer(sphere, lat)
    np.testing.assert_allclose(d.ffd(), sphere.vertices, atol=1e-12)
    J = d.jacobians()
    np.testing.assert_allclose(J, np.broadcast_to(np.eye(3), J.shape), atol=1e-11)


def test_user_knots_and_basis_matrix(sphere):
    knots = [[0, 0, 0, 0.2, 0.7, 1, 1, 1], [0, 0, 0, 0, 0.5, 1, 1, 1, 1], [0, 0, 0.3, 0.55, 0.8, 1, 1]]
    lat = vpffd.Lattice([-1.1] * 3, [1.1] * 3, shape=(5, 5, 5), degree=(2, 3, 1), knots=knots)
    d = vpffd.Deformer(sphere, lat)
    np.testing.assert_allclose(d.ffd(), sphere.vertices, atol=1e-12)
    P = vpffd.twist(lat.control_points, 40)
    B = d.basis_matrix()
    assert isinstance(B, sp.csr_matrix) and B.shape == (sphere.n_vertices, 125)
    np.testing.assert_allclose(B @ P.reshape(-1, 3), d.ffd(P), atol=1e-13)
    np.testing.assert_allclose(lat.deform_points(sphere.vertices, P), d.ffd(P), atol=1e-13)


def test_numeric_range_of_lattices_and_points(sphere):
    with pytest.raises(InvalidInputError, match="repeated more than"):
        vpffd.Lattice([-2] * 3, [2] * 3, degree=3, knots=[[0, 0, 0, 0, 1, 1, 1, 1, 1]] * 3)
    with pytest.raises(InvalidInputError, match="extent"):
        vpffd.Lattice([-1e308] * 3, [1e308] * 3, shape=4)
    with pytest.raises(InvalidInputError, match="extent"):
        vpffd.Lattice([0] * 3, [1e-320] * 3, shape=4)
    lat = vpffd.Lattice([-2] * 3, [2] * 3, shape=4)
    with pytest.raises(InvalidInputError, match="too far"):
        lat.deform_points([[1e300, 0, 0]], outside="extrapolate")
    with pytest.raises(InvalidInputError, match="at most"):
        vpffd.Lattice([-2] * 3, [2] * 3, shape=(2 ** 30, 4, 4))
    with pytest.raises(InvalidInputError, match="not finite"):
        vpffd._core.basis_functions_fast(vpffd._core.clamped_uniform_knots(5, 3), 3, [float("nan"), 0.5])
    with pytest.raises(InvalidInputError, match="refers to vertex"):
        vpffd._core.signed_volume(sphere.vertices, np.array([[0, 1, 2_000_000_000]], np.int32), np.zeros(3))


def test_extrapolate_policy(sphere):
    small = vpffd.Lattice([-0.8] * 3, [0.8] * 3, shape=5)
    d = vpffd.Deformer(sphere, small, outside="extrapolate")
    np.testing.assert_allclose(d.ffd(), sphere.vertices, atol=1e-12)
    with pytest.raises(InvalidInputError, match="outside"):
        vpffd.Deformer(sphere, small, outside="clamp")


def test_edits_return_new_points(lat):
    P0 = lat.control_points.copy()
    for f in (lambda P: vpffd.twist(P, 90), lambda P: vpffd.bend(P, 45), lambda P: vpffd.taper(P, 0.5),
              lambda P: vpffd.scale(P, 2.0), lambda P: vpffd.squash(P, 0.5)):
        Q = f(lat.control_points)
        assert Q.shape == P0.shape and not np.allclose(Q, P0)
        np.testing.assert_array_equal(lat.control_points, P0)
    np.testing.assert_allclose(vpffd.twist(P0, 0), P0)
    np.testing.assert_allclose(vpffd.bend(P0, 0), P0)
    # A 90 degree twist turns the top layer by 90 degrees about the centre.
    Q = vpffd.twist(P0, 90)
    c = lat.center
    top = P0[:, :, -1] - c
    np.testing.assert_allclose((Q[:, :, -1] - c)[..., 0], -top[..., 1], atol=1e-12)
