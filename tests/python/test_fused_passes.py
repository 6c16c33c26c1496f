"""The core's fused passes against the straightforward routes they replace:
deformed normals without the (V, 3, 3) Jacobians, B^T w without the basis
matrix, the per-face cone volumes, and the automatic weights built on them."""
import numpy as np
import pytest

import vpffd
from vpffd import InvalidInputError, _core
from vpffd.local_weights import AUTO_EPS, auto_weights, local_volume_change


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
    # The same products in the same order per vertex: equal to rounding of the unit vectors.
    assert np.abs(got - ref).max() <= 1e-14
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
    # Each sum has at most V terms |B_c w_v| <= |w_v|, reordered: within V eps sum |w|.
    assert np.abs(got - ref).max() <= d.mesh.n_vertices * 2.2e-16 * np.abs(w).sum()
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
    assert np.abs(got - ref).max() <= 1e-12 * ref.max()
    w = auto_weights(d, P)
    r = ref / ref.max()
    # |dw / w| = |d(r^2)| / (r^2 + eps) <= |dr| / sqrt(eps), |dr| ~ 2e-12: below 1e-8.
    np.testing.assert_allclose(w, 1.0 / (r * r + AUTO_EPS), rtol=1e-8)
    # The rest cones are kept for the rest mesh they were computed for.
    d.set_rest_vertices(d.mesh.vertices + 0.01)
    np.testing.assert_allclose(local_volume_change(d, P), _local_volume_change_by_matrix(d, P),
                               rtol=0, atol=1e-12 * ref.max())
