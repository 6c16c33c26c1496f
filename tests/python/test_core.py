"""The core of issue 2 through the Python API: FFD, volume, corrections, bad input."""
import numpy as np
import pytest
import scipy.sparse as sp

import vpffd
from vpffd import InvalidInputError, SolverError


@pytest.fixture(scope="module")
def sphere():
    return vpffd.shapes.icosphere(3)


@pytest.fixture(scope="module")
def lat(sphere):
    return vpffd.Lattice.around(sphere, shape=(6, 6, 6), degree=3, padding=0.05)


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


def test_face_matrix_is_the_papers(sphere, lat):
    d = vpffd.Deformer(sphere, lat)
    X = d.ffd(vpffd.squash(lat.control_points, 0.5))
    M = d.face_matrix()
    V, F = X, sphere.faces
    e1, e2 = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    nx = np.cross(e1, e2)[:, 0]
    alpha, vol = d.volume_coefficients(X, "x")
    np.testing.assert_allclose(M @ nx, alpha, rtol=1e-12, atol=1e-14)
    alpha_csr, vol_csr = d.volume_coefficients(X, "x", method="csr")
    np.testing.assert_allclose(alpha_csr, alpha, rtol=1e-12, atol=1e-15)
    assert vol == pytest.approx(vpffd.Mesh(X, F).volume, rel=1e-13)
    assert d.face_matrix_nnz() == M.nnz


@pytest.mark.parametrize("axes", ["x", "y", "z", "xy", "xz", "yz", "zy", "xyz", "zxy"])
@pytest.mark.parametrize("edit", ["squash", "twist"])
@pytest.mark.parametrize("method", ["traversal", "csr"])
def test_volume_restored(sphere, lat, axes, edit, method):
    d = vpffd.Deformer(sphere, lat)
    P = vpffd.squash(lat.control_points, 0.2) if edit == "squash" else vpffd.twist(lat.control_points, 360)
    r = d.deform(P, axes=axes, method=method)
    assert abs(r.volume - d.rest_volume) <= 1e-12 * d.rest_volume
    assert abs(r.volume_before - d.rest_volume) > 1e-3 * d.rest_volume
    assert abs(vpffd.Mesh(r.vertices, sphere.faces).volume - r.volume) <= 1e-13 * r.volume
    off = r.offsets.reshape(-1, 3)
    for a in range(3):
        if "xyz"[a] not in axes:
            assert not off[:, a].any()
    np.testing.assert_allclose(r.control_points, P + r.offsets, atol=1e-15)


def test_target_volume_and_backends_agree(sphere, lat):
    P = vpffd.bend(lat.control_points, 60)
    rs = vpffd.Deformer(sphere, lat, backend="serial").deform(P, target_volume=3.0)
    ro = vpffd.Deformer(sphere, lat, backend="openmp").deform(P, target_volume=3.0)
    assert rs.volume == pytest.approx(3.0, rel=1e-12)
    np.testing.assert_array_equal(rs.vertices, ro.vertices)
    assert "serial" in vpffd.available_backends()


def test_weighted_offsets_are_optimal(sphere, lat):
    d = vpffd.Deformer(sphere, lat)
    P = vpffd.squash(lat.control_points, 0.5)
    w = np.random.default_rng(0).uniform(0.5, 5.0, lat.shape)
    r = d.deform(P, weights=w, axes="xy")
    X = d.ffd(P)
    B = d.basis_matrix()
    for a in (0, 1):
        alpha, _ = d.volume_coefficients(X, a)
        g = alpha / w.reshape(-1)
        off = r.offsets.reshape(-1, 3)[:, a]
        k = off @ g / (g @ g)
        np.testing.assert_allclose(off, k * g, atol=1e-12 * np.abs(off).max())
        X[:, a] += B @ off
    np.testing.assert_allclose(X, r.vertices, atol=1e-13)


def test_constraints_and_fixed(sphere, lat):
    d = vpffd.Deformer(sphere, lat)
    fixed = np.zeros(lat.shape, bool)
    fixed[:, :, 0] = True
    targets = [(0, sphere.vertices[0] * 1.2), ((0.1, 0.2, 0.3), (0.1, 0.25, 0.35)),
               (7, sphere.vertices[7] + (0.05, 0, -0.05))]
    r = d.deform(vpffd.squash(lat.control_points, 0.7), constraints=targets, fixed=fixed)
    assert abs(r.volume - d.rest_volume) <= 1e-12 * d.rest_volume
    assert r.constraint_error <= 1e-12
    np.testing.assert_allclose(r.vertices[0], sphere.vertices[0] * 1.2, atol=1e-12)
    np.testing.assert_allclose(lat.deform_points([(0.1, 0.2, 0.3)], r.control_points)[0], (0.1, 0.25, 0.35),
                               atol=1e-12)
    assert not r.offsets[:, :, 0].any()
    # Optimality with constraints: each axis offset lies in the span of alpha and the constraint rows.
    X = d.ffd(vpffd.squash(lat.control_points, 0.7))
    B = d.basis_matrix()
    Bp = lat.basis_matrix([(0.1, 0.2, 0.3)]).toarray()[0]
    np.testing.assert_allclose(lat.basis_matrix(sphere.vertices[[0, 7]]).toarray(), B[[0, 7]].toarray())
    rows = [B[0].toarray()[0], Bp, B[7].toarray()[0]]
    free = ~fixed.reshape(-1)
    for a in range(3):
        alpha, _ = d.volume_coefficients(X, a)
        A = np.stack([alpha] + rows)[:, free].T
        off = r.offsets.reshape(-1, 3)[free, a]
        coef, *_ = np.linalg.lstsq(A, off, rcond=None)
        np.testing.assert_allclose(A @ coef, off, atol=1e-12 * np.abs(off).max())
        X[:, a] += B @ r.offsets.reshape(-1, 3)[:, a]


def test_solver_errors(sphere, lat):
    d = vpffd.Deformer(sphere, lat)
    P = vpffd.squash(lat.control_points, 0.5)
    with pytest.raises(SolverError, match="only 0 free control points"):
        d.deform(P, fixed=np.ones(lat.shape, bool))
    # In a lattice three times the sphere's size, the outer layer of control
    # points does not reach the sphere: with all others fixed nothing can act.
    big = vpffd.Lattice.around(sphere, shape=8, padding=1.0)
    only_outer = np.ones(big.shape, bool)
    only_outer[0] = False
    with pytest.raises(SolverError, match="all zero"):
        vpffd.Deformer(sphere, big).deform(vpffd.squash(big.control_points, 0.5), fixed=only_outer)
    with pytest.raises(SolverError, match="dependent"):
        d.deform(P, constraints=[(3, sphere.vertices[3]), (3, sphere.vertices[3] + 0.1)])
    with pytest.raises(SolverError, match="free control points"):
        d.deform(P, constraints=[(i, sphere.vertices[i]) for i in range(300)])
    with pytest.raises(InvalidInputError, match="not among the corrected axes"):
        d.deform(P, axes="z", constraints=[(0, sphere.vertices[0] + (0.1, 0, 0))])


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
    with pytest.raises(InvalidInputError, match="vertex 99999 out of range"):
        d.deform(constraints=[(99999, (0, 0, 0))])
    with pytest.raises(InvalidInputError, match="backend"):
        vpffd.Deformer(sphere, lat, backend="cuda")
    with pytest.raises(InvalidInputError, match="method"):
        d.deform(method="dense")
    with pytest.raises(InvalidInputError, match="target_volume"):
        d.deform(target_volume=float("inf"))


def test_open_mesh_allowed_with_warning(sphere, lat):
    m = vpffd.Mesh(sphere.vertices, sphere.faces[:-1])
    d = vpffd.Deformer(m, lat)
    with pytest.warns(UserWarning, match="not closed"):
        r = d.deform(vpffd.squash(lat.control_points, 0.5), allow_open=True)
    assert abs(r.volume - r.rest_volume) <= 1e-12 * abs(r.rest_volume)


def test_extrapolate_policy(sphere):
    small = vpffd.Lattice([-0.8] * 3, [0.8] * 3, shape=5)
    d = vpffd.Deformer(sphere, small, outside="extrapolate")
    np.testing.assert_allclose(d.ffd(), sphere.vertices, atol=1e-12)
    with pytest.raises(InvalidInputError, match="outside"):
        vpffd.Deformer(sphere, small, outside="clamp")


def test_rounds_spread_the_correction_evenly(sphere, lat):
    d = vpffd.Deformer(sphere, lat)
    P = vpffd.squash(lat.control_points, 0.3)
    widths = {}
    for rounds in (1, 4):
        r = d.deform(P, axes="xy", rounds=rounds, constraints=[(0, d.ffd(P)[0])])
        assert abs(r.volume - d.rest_volume) <= 1e-12 * d.rest_volume
        assert r.constraint_error <= 1e-12
        assert len(r.steps) == 2 * rounds
        widths[rounds] = np.ptp(r.vertices, axis=0)
    # The paper's x-then-y order widens x more than y; rounds even it out.
    assert widths[1][0] / widths[1][1] > 1.02
    assert abs(widths[4][0] / widths[4][1] - 1) < 0.5 * abs(widths[1][0] / widths[1][1] - 1)
    with pytest.raises(InvalidInputError, match="rounds"):
        d.deform(P, rounds=0)


def test_weights_scale_free_and_overflow(sphere, lat):
    d = vpffd.Deformer(sphere, lat)
    P = vpffd.squash(lat.control_points, 0.5)
    r1 = d.deform(P)
    for w in (1e300, 1e-300, 3.5):
        rw = d.deform(P, weights=np.full(lat.shape, w))
        np.testing.assert_allclose(rw.vertices, r1.vertices, atol=1e-13)
    with pytest.raises(InvalidInputError, match="overflows"):
        d.deform(P, weights=np.full(lat.shape, 1e-320))
    with pytest.raises(SolverError, match="overflow"):
        d.deform(P * 1e155)


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
    r = d.deform(target_volume=0.0, axes="z")
    assert abs(r.volume) <= 1e-12 * d.rest_volume  # volume_error is relative: inf for a zero target
    assert 100 < d.bytes_per_vertex < 250  # embedding, orders, faces, face lists, rest vertices


def test_open_mesh_animation_without_preservation(sphere, lat):
    m = vpffd.Mesh(sphere.vertices, sphere.faces[:-1])
    anim = vpffd.run_animation(m, lat, vpffd.animate.Twist(lat, angle=90), frames=3, preserve=False)
    assert np.isnan(anim.rest_volume)
    with pytest.raises(InvalidInputError, match="deformer"):
        vpffd.run_animation(sphere, lat, vpffd.animate.Twist(lat, angle=90), frames=3,
                            deformer=vpffd.Deformer(vpffd.shapes.icosphere(2), lat))
