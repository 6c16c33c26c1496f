"""The volume correction (paper 000, Problems 1-2, Remark 2) through the Python API: exact volumes, targets, weights, constraints, fixed points, rounds, solver errors."""
import numpy as np
import pytest

import vpffd
from vpffd import InvalidInputError, SolverError



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
