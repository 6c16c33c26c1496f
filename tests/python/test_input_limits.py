"""Inputs at the edge of what the core can represent (issue 9): knot vectors that
disagree with the shape, lattices too big for memory, meshes of extreme size,
degenerate faces on open meshes."""
import numpy as np
import pytest

import vpffd
from vpffd import InvalidInputError
from vpffd import lattice as lattice_module


def test_shape_must_match_the_knots():
    k5 = [0, 0, 0, 0, 0.5, 1, 1, 1, 1]  # 5 control points of degree 3
    with pytest.raises(InvalidInputError, match=r"shape \(7, 7, 7\) does not match the knots.*\(5, 5, 5\)"):
        vpffd.Lattice([-1] * 3, [1] * 3, shape=(7, 7, 7), degree=3, knots=[k5, k5, k5])
    # Left out, the shape is what the knots give; given and equal, it is accepted.
    assert vpffd.Lattice([-1] * 3, [1] * 3, degree=3, knots=[k5, k5, k5]).shape == (5, 5, 5)
    assert vpffd.Lattice([-1] * 3, [1] * 3, shape=5, degree=3, knots=[k5, k5, k5]).shape == (5, 5, 5)
    with pytest.raises(InvalidInputError, match="three"):
        vpffd.Lattice([-1] * 3, [1] * 3, degree=3, knots=[k5, k5])
    with pytest.raises(InvalidInputError, match="1-D"):
        vpffd.Lattice([-1] * 3, [1] * 3, degree=3, knots=[k5, k5, [k5]])


@pytest.mark.parametrize("knots, why", [
    # interior knot 0.5 four times for degree 3: the deformation would tear
    ([0, 0, 0, 0, .5, .5, .5, .5, 1, 1, 1, 1], "repeated 4 times"),
    # the domain starts at 0.5, repeated 3 times with degree 2: the first control
    # plane's basis function ends where the domain starts
    ([0, 0, .5, .5, .5, .7, 1, 1, 1], "first control plane"),
    ([0, 0, 0, .3, .5, .5, .5, 1, 1], "last control plane"),
])
def test_knot_multiplicity_beyond_degree_is_refused(knots, why):
    d = 3 if len(knots) == 12 else 2
    with pytest.raises(InvalidInputError, match=why):
        vpffd.Lattice([-1] * 3, [1] * 3, degree=d, knots=[knots] * 3)


def test_lattices_too_big_for_memory_are_refused_up_front(monkeypatch):
    monkeypatch.setattr(lattice_module, "_available_memory", lambda: 4 * 2 ** 30)
    # 1000 x 1000 x 100 = 1e8 points, under the count cap, about 6.7 GiB for the lattice alone.
    with pytest.raises(InvalidInputError, match=r"need about 6\.7 GiB .* only 4\.0 GiB"):
        vpffd.Lattice([-1] * 3, [1] * 3, shape=(1000, 1000, 100), degree=1)
    lat = vpffd.Lattice([-1.5] * 3, [1.5] * 3, shape=(60, 60, 60), degree=1)  # 216k points, 15 MiB
    monkeypatch.setattr(lattice_module, "_available_memory", lambda: 2 ** 20)
    with pytest.raises(InvalidInputError, match="Deformer: 216,000 control points need about"):
        vpffd.Deformer(vpffd.shapes.icosphere(1), lat)
    monkeypatch.setattr(lattice_module, "_available_memory", lambda: None)  # unknown: no check
    vpffd.Deformer(vpffd.shapes.icosphere(1), lat)


@pytest.mark.parametrize("size", [1e-100, 1e-30, 1e30, 1e100])
def test_extreme_mesh_sizes_are_corrected_exactly(size):
    # Relative rounding does not depend on the scale (no under- or overflow in between),
    # so the bound is the one at size 1: a volume of F terms summed in double.
    mesh = vpffd.shapes.icosphere(2, radius=size)
    lat = vpffd.Lattice.around(mesh, shape=(5, 5, 5), degree=3)
    d = vpffd.Deformer(mesh, lat, backend="serial")
    r = d.deform(vpffd.squash(lat.control_points, 0.6), axes="xy")
    assert abs(r.volume - d.rest_volume) <= 1e-12 * d.rest_volume
    assert np.isfinite(r.vertices).all()
    unit = vpffd.Deformer(vpffd.shapes.icosphere(2), vpffd.Lattice.around(vpffd.shapes.icosphere(2),
                                                                          shape=(5, 5, 5), degree=3))
    ru = unit.deform(vpffd.squash(unit.lattice.control_points, 0.6), axes="xy")
    np.testing.assert_allclose(r.vertices / size, ru.vertices, atol=1e-12)


def test_volume_that_overflows_double_is_named():
    mesh = vpffd.shapes.icosphere(2, radius=1e150)
    lat = vpffd.Lattice.around(mesh, shape=4, degree=3)
    with pytest.raises(InvalidInputError, match="volume overflows double precision"):
        vpffd.Deformer(mesh, lat)


def test_degenerate_face_on_an_open_mesh_keeps_the_target():
    # A face (a, a, b) has no cone volume; its two corners at a must cancel.
    sphere = vpffd.shapes.icosphere(3)
    F = sphere.faces.copy()
    F = np.vstack([F[:-1], [[F[0, 0], F[0, 0], F[0, 1]]]])
    mesh = vpffd.Mesh(sphere.vertices, F)
    lat = vpffd.Lattice.around(mesh, shape=6, degree=3)
    d = vpffd.Deformer(mesh, lat)
    with pytest.warns(UserWarning, match="not closed"):
        r = d.deform(vpffd.squash(lat.control_points, 0.5), allow_open=True)
    assert abs(r.volume - r.rest_volume) <= 1e-12 * abs(r.rest_volume)
    # The paper's sparse-matrix path measures the projection form, which is only
    # defined on closed meshes; the traversal's coefficients give exactly the volume's
    # derivative, checked here against a finite difference along x.
    X = d.ffd(vpffd.squash(lat.control_points, 0.5))
    alpha, vol = d.volume_coefficients(X, "x")
    P = vpffd.squash(lat.control_points, 0.5)
    h = 1e-6
    # The control point that weighs most on the degenerate face's vertex; V is linear in
    # the x column of the vertices, so the difference quotient is exact but for rounding
    # (|V| eps / h ~ 1e-10 of alpha h here).
    i = int(np.argmax(lat.basis_matrix(sphere.vertices[[F[-1, 0]]]).toarray()[0]))
    Q = P.copy().reshape(-1, 3)
    Q[i, 0] += h
    Xh = d.ffd(Q.reshape(P.shape))
    _, vol_h = d.volume_coefficients(Xh, "x")
    assert vol_h - vol == pytest.approx(alpha[i] * h, rel=1e-6)


def test_outside_message_is_plural_english():
    mesh = vpffd.shapes.icosphere(2)
    small = vpffd.Lattice([-0.5] * 3, [0.5] * 3, shape=4)
    with pytest.raises(InvalidInputError, match=r"\d+ vertices lie outside"):
        vpffd.Deformer(mesh, small)
