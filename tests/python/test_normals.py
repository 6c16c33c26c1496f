"""Deformed normals: exact (cofactor of the FFD Jacobian) vs the mapped-tangent
approximation (001_589bf8d97509b8d4.txt, Section 2.4) vs normals recomputed
from the deformed triangles."""
import numpy as np
import pytest

import vpffd
from vpffd.normals import angles_deg


@pytest.fixture(scope="module")
def setup():
    mesh = vpffd.shapes.icosphere(4)
    lat = vpffd.Lattice.around(mesh, shape=(5, 5, 5))
    rng = np.random.default_rng(7)
    P = vpffd.edits.twist(lat.control_points, 1.0) + rng.normal(scale=0.08, size=lat.control_points.shape)
    d = vpffd.Deformer(mesh, lat)
    r = d.deform(P)
    return mesh, lat, d, r


def test_identity_keeps_normals():
    mesh = vpffd.shapes.icosphere(2)
    lat = vpffd.Lattice.around(mesh, shape=(4, 4, 4))
    d = vpffd.Deformer(mesh, lat)
    n0 = vpffd.vertex_normals(mesh)
    for method in ("exact", "tangent"):
        assert angles_deg(vpffd.deformed_normals(d, method=method), n0).max() < 1e-6


def test_affine_map_is_exact_for_both():
    """Under a linear map A, normals transform by cof(A) exactly."""
    mesh = vpffd.shapes.icosphere(2)
    lat = vpffd.Lattice.around(mesh, shape=(4, 4, 4))
    A = np.array([[1.5, 0.3, 0.0], [0.0, 0.7, 0.2], [0.1, 0.0, 1.2]])
    P = lat.control_points @ A.T
    d = vpffd.Deformer(mesh, lat)
    n0 = vpffd.vertex_normals(mesh)
    want = n0 @ (np.linalg.det(A) * np.linalg.inv(A))  # rows: (cof(A) n)^T
    assert angles_deg(vpffd.deformed_normals(d, P), want).max() < 1e-9
    assert angles_deg(vpffd.deformed_normals(d, P, method="tangent"), want).max() < 1e-5
    # The deformed triangles' normals are exact here too: a linear map keeps planes planar.
    rec = vpffd.vertex_normals(vpffd.Mesh(d.ffd(P), mesh.faces))
    assert angles_deg(rec, want).max() < 5.0


def test_angles_between_methods(setup):
    mesh, lat, d, r = setup
    exact = vpffd.deformed_normals(d, r.control_points)
    approx = vpffd.deformed_normals(d, r.control_points, method="tangent")
    recomputed = vpffd.vertex_normals(vpffd.Mesh(r.vertices, mesh.faces))
    a_ex_ap = angles_deg(exact, approx)
    a_ex_re = angles_deg(exact, recomputed)
    a_ap_re = angles_deg(approx, recomputed)
    np.testing.assert_allclose(np.linalg.norm(exact, axis=1), 1.0, atol=1e-12)
    # The finite differences (eps = 1e-4 of the box) agree with the cofactor to
    # a small fraction of a degree ...
    assert a_ex_ap.max() < 0.05 and a_ex_ap.mean() < 0.01
    # ... and both agree with the deformed triangles to the discretisation error
    # of vertex normals on this mesh (2,562 vertices): degrees at most.
    assert a_ex_re.mean() < 1.0 and a_ex_re.max() < 5.0
    assert abs(a_ap_re.mean() - a_ex_re.mean()) < 0.05
    # Exact normals point outward like the triangles do.
    assert (np.einsum("ij,ij->i", exact, recomputed) > 0.9).all()


def test_tangent_error_shrinks_with_eps(setup):
    mesh, lat, d, r = setup
    exact = vpffd.deformed_normals(d, r.control_points)
    diag = np.linalg.norm(lat.box_max - lat.box_min)
    errs = [angles_deg(exact, vpffd.deformed_normals(d, r.control_points, method="tangent", eps=e * diag)).max()
            for e in (1e-1, 1e-2, 1e-3)]
    assert errs[0] > errs[1] > errs[2]
    assert errs[1] / errs[2] > 5  # first order in eps


def test_exact_tracks_refinement():
    """On finer meshes the recomputed normals converge to the exact ones."""
    means = []
    for s in (2, 3, 4):
        mesh = vpffd.shapes.icosphere(s)
        lat = vpffd.Lattice.around(mesh, shape=(4, 4, 4))
        d = vpffd.Deformer(mesh, lat)
        P = vpffd.edits.twist(lat.control_points, 1.2)
        ex = vpffd.deformed_normals(d, P)
        re = vpffd.vertex_normals(vpffd.Mesh(d.ffd(P), mesh.faces))
        means.append(angles_deg(ex, re).mean())
    assert means[0] > means[1] > means[2]


def test_bad_arguments(setup):
    mesh, lat, d, r = setup
    with pytest.raises(TypeError):
        vpffd.deformed_normals("deformer")
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.deformed_normals(d, method="magic")
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.deformed_normals(d, method="tangent", eps=-1)
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.deformed_normals(d, rest_normals=np.zeros((3, 3)))
    with pytest.raises(vpffd.InvalidInputError):
        angles_deg(np.zeros((2, 3)), np.zeros((3, 3)))
