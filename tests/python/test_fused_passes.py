"""The core's fused passes against the straightforward routes they replace:
deformed normals without the (V, 3, 3) Jacobians, B^T w without the basis
matrix, the per-face cone volumes, and the automatic weights built on them."""
import numpy as np
import pytest

import vpffd
from vpffd import InvalidInputError, _core
from vpffd.local_weights import AUTO_EPS, auto_weights, local_volume_change

U = np.finfo(float).eps / 2  # unit roundoff


def _scatter_bound(d, n_terms):
    """Relative bound (times sum |w|) on B^T w computed two ways (the cell's power form,
    the basis matrix), as tests/cpp/test_cell_runs.cpp derives it: each basis value
    within 2 (3K + 6) u K^3 (K cmax)^3 and each sum within 2 (n + 3K) u (K cmax)^3 per
    unit of weight, with cmax <= 2^d (a B-spline piece's power coefficients on its
    span: Bernstein coefficients <= 1 times binomials summing to 2^d)."""
    deg = int(np.max(d.lattice.degree))
    K = deg + 1
    p3 = (K * 2.0 ** deg) ** 3
    return (2 * (3 * K + 6) * K ** 3 * p3 + 2 * (n_terms + 3 * K) * p3) * U


def _cases():
    """(deformer, control points) on a plain lattice, a closed periodic one and a
    twist seam that a sphere straddles (its wrapped half has mirrored Jacobians)."""
    rng = np.random.default_rng(11)
    sphere = vpffd.shapes.icosphere(3)
    plain = vpffd.Lattice.around(sphere, shape=(5, 6, 5))
    out = [(vpffd.Deformer(sphere, plain, threads=2),
            vpffd.edits.twist(plain.control_points, 1.0) + rng.normal(scale=0.05, size=plain.control_points.shape))]
    for seam in ("closed", "twist"):
        lat = vpffd.Lattice((-1, -1, -1), (1, 1, 1), shape=(7, 4, 4), degree=3, periodic="x", seam=seam)
        mesh = vpffd.Mesh(0.4 * sphere.vertices + [0.95, 0.1, -0.1], sphere.faces)  # across x = 1
        P = lat.control_points + rng.normal(scale=0.04, size=lat.control_points.shape)
        out.append((vpffd.Deformer(mesh, lat, threads=2), P))
    return out


@pytest.mark.parametrize("case", range(3))
def test_deformed_normals_are_the_jacobian_route(case):
    d, P = _cases()[case]
    N0 = vpffd.vertex_normals(d.mesh)
    J = np.ascontiguousarray(d.jacobians(P).reshape(-1, 9))
    ref = _core.deformed_normals_exact(J, N0)
    got = vpffd.deformed_normals(d, P)
    # The same Jacobians and formula, possibly contracted into fused multiply-adds
    # differently: each component of cof(J) n is a sum of six products of three
    # factors, within 16 u S of the exact one, S = sum_k |n_k| |c_i| |c_j| (the columns'
    # lengths), and normalising keeps that relative to |cof(J) n| (twice: both sides).
    Jm = J.reshape(-1, 3, 3)
    c = np.linalg.norm(Jm, axis=1)  # column lengths
    S = (np.abs(N0[:, 0]) * c[:, 1] * c[:, 2] + np.abs(N0[:, 1]) * c[:, 2] * c[:, 0] +
         np.abs(N0[:, 2]) * c[:, 0] * c[:, 1])
    cof_n = np.linalg.det(Jm)[:, None] * np.einsum("vji,vj->vi", np.linalg.inv(Jm), N0)  # det(J) J^-T n
    assert (np.abs(got - ref).max(axis=1) <= 2 * 16 * U * S / np.linalg.norm(cof_n, axis=1)).all()
    assert np.array_equal(got, d._d.deformed_normals(d._P(P), N0, 1))  # any thread count, same bits
    with pytest.raises(InvalidInputError, match="rest normals"):
        d._d.deformed_normals(d._P(P), N0[:-1], 1)
    bad = N0.copy()
    bad[3, 1] = np.nan
    with pytest.raises(InvalidInputError, match="NaN"):
        d._d.deformed_normals(d._P(P), bad, 1)


@pytest.mark.parametrize("case", range(3))
def test_basis_transpose_is_the_matrix_transpose(case):
    d, _ = _cases()[case]
    w = np.random.default_rng(case).normal(size=d.mesh.n_vertices)
    B = d.lattice._fold_columns(d._extended_basis())
    ref = np.asarray(B.T @ w).reshape(-1)
    got = d._d.basis_transpose(w, 2)
    assert got.shape == (d.n_control_points,)
    tol = _scatter_bound(d, d.mesh.n_vertices) * np.abs(w).sum()
    assert np.abs(got - ref).max() <= tol
    assert np.abs(ref).max() > 100 * tol  # meaningful: a wrong cell errs by O(|ref|)
    assert np.array_equal(got, d._d.basis_transpose(w, 1))
    with pytest.raises(InvalidInputError, match="values for"):
        d._d.basis_transpose(w[:-1], 1)


def test_cone_volumes_sum_to_the_volume():
    m = vpffd.shapes.icosphere(3)
    c = np.array([0.1, -0.2, 0.3])
    cones = _core.cone_volumes(m.vertices, m.faces, c)
    assert cones.shape == (m.n_faces,)
    assert cones.sum() == pytest.approx(_core.signed_volume(m.vertices, m.faces, c), rel=1e-14)
    with pytest.raises(InvalidInputError):
        _core.cone_volumes(m.vertices, m.faces + m.n_vertices, c)


def _local_volume_change_by_matrix(d, P):
    """The formula of local_weights' docstring with numpy and the basis matrix."""
    c, F = d.lattice.center, d.mesh.faces

    def cones(X):
        a, b, e = (X[F[:, i]] - c for i in range(3))
        return np.einsum("ij,ij->i", a, np.cross(b, e)) / 6.0

    dV = np.abs(cones(d.ffd(P)) - cones(d.mesh.vertices))
    per_vertex = np.zeros(d.mesh.n_vertices)
    for i in range(3):
        np.add.at(per_vertex, F[:, i], dV / 3.0)
    return np.asarray(d.lattice._fold_columns(d._extended_basis()).T @ per_vertex).reshape(-1)


@pytest.mark.parametrize("case", range(3))
def test_auto_weights_as_by_the_matrix(case):
    d, P = _cases()[case]
    ref = _local_volume_change_by_matrix(d, P)
    got = local_volume_change(d, P)
    # Each face's |dV| is within 2 x 8 u of its two cones' sizes (numpy and the core
    # order the triple product differently) and goes to its vertices with basis
    # weights summing to 1; the two scatters differ within _scatter_bound.
    c = d.lattice.center
    size = sum(np.abs(_core.cone_volumes(X, d.mesh.faces, c)).sum() for X in (d.ffd(P), d.mesh.vertices))
    tol = 16 * U * size + _scatter_bound(d, d.mesh.n_vertices) * size
    assert np.abs(got - ref).max() <= tol
    assert ref.max() > 100 * tol
    w = auto_weights(d, P)
    r = ref / ref.max()
    # |dw / w| = |d(r^2)| / (r^2 + eps) <= |dr| / sqrt(eps), |dr| <= 2 tol / max L, plus rounding.
    np.testing.assert_allclose(w, 1.0 / (r * r + AUTO_EPS), rtol=(2 * tol / ref.max() + 8 * U) / np.sqrt(AUTO_EPS))
    # The rest cones are kept for the rest mesh they were computed for.
    d.set_rest_vertices(d.mesh.vertices + 0.01)
    np.testing.assert_allclose(local_volume_change(d, P), _local_volume_change_by_matrix(d, P), rtol=0, atol=2 * tol)
