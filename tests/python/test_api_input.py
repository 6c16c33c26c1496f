"""Bad input to the Python API: clear errors naming the argument, caller arrays untouched, open meshes."""
import numpy as np
import pytest

import vpffd
from vpffd import InvalidInputError



def test_caller_arrays_untouched(sphere, lat):
    V = sphere.vertices.copy()
    F = sphere.faces.astype(np.int64)
    P = vpffd.twist(lat.control_points, 90)
    P_copy, F_copy = P.copy(), F.copy()
    w = np.ones(lat.shape)
    m = vpffd.Mesh(V, F)
    d = vpffd.Deformer(m, lat)
    d.deform(P, weights=w, constraints=[(0, V[0])])
    np.testing.assert_array_equal(P, P_copy)
    np.testing.assert_array_equal(F, F_copy)
    np.testing.assert_array_equal(w, 1.0)
    assert not m.vertices.flags.writeable


def test_bounds_are_numpys_and_read_only(sphere):
    from vpffd import _arrays
    rng = np.random.default_rng(3)
    for V in (rng.normal(size=(1, 3)), rng.normal(size=(1001, 3)) * [1e-300, 1.0, 1e300], sphere.vertices):
        lo, hi = _arrays.bounds(V)
        assert np.array_equal(lo, V.min(axis=0)) and np.array_equal(hi, V.max(axis=0))
    m = vpffd.Mesh(sphere.vertices, sphere.faces)
    box = m.bounds
    np.testing.assert_array_equal(box, [sphere.vertices.min(axis=0), sphere.vertices.max(axis=0)])
    assert box.shape == (2, 3) and not box.flags.writeable
    # A mesh with new vertices has its own box (the cached one is not carried over).
    moved = m._with_vertices(sphere.vertices + [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(moved.bounds, box + [1.0, 2.0, 3.0])
    assert moved.volume == pytest.approx(m.volume, rel=1e-13)


def test_bad_input(sphere, lat):
    V, F = sphere.vertices, sphere.faces
    with pytest.raises(InvalidInputError, match=r"shape \(n, 3\)"):
        vpffd.Mesh(V[:, :2], F)
    with pytest.raises(TypeError, match="integer"):
        vpffd.Mesh(V, F.astype(float))
    with pytest.raises(TypeError, match="real numbers"):
        vpffd.Mesh(V.astype(complex), F)
    Vn = V.copy()
    Vn[4, 1] = np.nan
    with pytest.raises(InvalidInputError, match="row 4"):
        vpffd.Mesh(Vn, F)
    Fb = F.copy()
    Fb[2, 0] = len(V)
    with pytest.raises(InvalidInputError, match="face 2 refers to vertex"):
        vpffd.Mesh(V, Fb)
    with pytest.raises(InvalidInputError, match="empty"):
        vpffd.Mesh(np.zeros((0, 3)), F)
    with pytest.raises(InvalidInputError, match="too small for degree"):
        vpffd.Lattice.around(sphere, shape=(3, 4, 4), degree=3)
    with pytest.raises(InvalidInputError, match="degree"):
        vpffd.Lattice.around(sphere, shape=8, degree=6)
    with pytest.raises(InvalidInputError, match="zero extent"):
        vpffd.Lattice.around(np.c_[V[:, :2], np.zeros(len(V))], shape=4)
    small = vpffd.Lattice([-0.5] * 3, [0.5] * 3, shape=4)
    with pytest.raises(InvalidInputError, match="outside the lattice"):
        vpffd.Deformer(sphere, small)
    open_mesh = vpffd.Mesh(V, F[:-2])
    with pytest.raises(InvalidInputError, match="boundary edges"):
        open_mesh.volume
    d_open = vpffd.Deformer(open_mesh, lat)
    with pytest.raises(InvalidInputError, match="boundary edges"):
        d_open.deform(lat.control_points)
    d = vpffd.Deformer(sphere, lat)
    with pytest.raises(InvalidInputError, match="weight"):
        d.deform(weights=np.zeros(lat.shape))
    with pytest.raises(InvalidInputError, match="weights"):
        d.deform(weights=np.ones(7))
    with pytest.raises(TypeError, match="boolean"):
        d.deform(fixed=np.zeros(lat.shape))
    with pytest.raises(InvalidInputError, match="axes"):
        d.deform(axes="xw")
    with pytest.raises(InvalidInputError, match="axes is empty"):
        d.deform(axes="")
    with pytest.raises(InvalidInputError, match="NaN"):
        d.deform(np.full(lat.control_points.shape, np.nan))
    with pytest.raises(InvalidInputError, match="control_points"):
        d.deform(np.zeros((5, 3)))
    with pytest.raises(InvalidInputError, match="constraint 0 names vertex 99999, but there are 642 vertices"):
        d.deform(constraints=[(99999, (0, 0, 0))])
    with pytest.raises(InvalidInputError, match="vertex -2 out of range"):
        d.deform(constraints=[(-2, (0, 0, 0))])
    with pytest.raises(InvalidInputError, match="backend"):
        vpffd.Deformer(sphere, lat, backend="cuda")
    with pytest.raises(InvalidInputError, match="method"):
        d.deform(method="dense")
    with pytest.raises(InvalidInputError, match="target_volume"):
        d.deform(target_volume=float("inf"))


def test_argument_types_are_named(sphere, lat):
    d = vpffd.Deformer(sphere, lat)
    with pytest.raises(TypeError, match="target"):
        d.deform(constraints=[(0, "abc")])
    with pytest.raises(TypeError, match="target_volume"):
        d.deform(target_volume="3")
    with pytest.raises(InvalidInputError, match="axis"):
        d.volume_coefficients(sphere.vertices, True)
    with pytest.raises(InvalidInputError, match="rounds"):
        d.deform(rounds=10 ** 10)
    with pytest.raises(InvalidInputError, match="threads"):
        vpffd.Deformer(sphere, lat, threads=10 ** 10)
    with pytest.raises(TypeError, match="padding"):
        vpffd.Lattice.around(sphere, padding="a")
    with pytest.raises(InvalidInputError, match=r"\(\.\.\., 3\)"):
        vpffd.twist(np.arange(24.0).reshape(4, 6), 10)
    with pytest.raises(InvalidInputError, match="zero or of the other sign.*allow_inversion"):
        d.deform(target_volume=0.0, axes="z")
    r = d.deform(target_volume=0.0, axes="z", allow_inversion=True)
    assert abs(r.volume) <= 1e-12 * d.rest_volume  # volume_error is relative: inf for a zero target
    assert 100 < d.bytes_per_vertex < 250  # embedding, orders, faces, face lists, rest vertices


def test_open_mesh_allowed_with_warning(sphere, lat):
    m = vpffd.Mesh(sphere.vertices, sphere.faces[:-1])
    d = vpffd.Deformer(m, lat)
    with pytest.warns(UserWarning, match="not closed"):
        r = d.deform(vpffd.squash(lat.control_points, 0.5), allow_open=True)
    assert abs(r.volume - r.rest_volume) <= 1e-12 * abs(r.rest_volume)


def test_open_mesh_animation_without_preservation(sphere, lat):
    m = vpffd.Mesh(sphere.vertices, sphere.faces[:-1])
    anim = vpffd.run_animation(m, lat, vpffd.animate.Twist(lat, angle=90), frames=3, preserve=False)
    assert np.isnan(anim.rest_volume)
    with pytest.raises(InvalidInputError, match="deformer"):
        vpffd.run_animation(sphere, lat, vpffd.animate.Twist(lat, angle=90), frames=3,
                            deformer=vpffd.Deformer(vpffd.shapes.icosphere(2), lat))
