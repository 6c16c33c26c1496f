"""MultiresDeformer with periodic lattices (the seams at the foot points), results as
trimesh meshes, and point constraints solved through the Deformer."""
import numpy as np
import pytest

import vpffd


def _diag(X):
    return float(np.linalg.norm(np.ptp(X, axis=0)))


@pytest.fixture(scope="module")
def long_body():
    """A bumpy body 5 units long in x, decomposed once."""
    mesh = vpffd.shapes.bumpy_sphere(3, amplitude=0.08, frequency=8.0, stretch=(2.5, 1.0, 1.0))
    return mesh, vpffd.Multires(mesh, smoothing=6)


def _short_box(mesh, seam, shape=(6, 5, 5)):
    """Periodic along x over a box about 40 % as long as the body: most foot points
    lie outside it along x and are wrapped (one or two periods)."""
    lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    pad = 0.05 * (hi - lo)
    lo, hi = lo - pad, hi + pad
    lo[0], hi[0] = -1.0, 1.0
    return vpffd.Lattice(lo, hi, shape=shape, degree=3, periodic="x", seam=seam)


def test_periodic_identity_is_exact(long_body):
    mesh, mr = long_body
    lat = _short_box(mesh, "shift")
    foot = mr.frame_data()["foot_points"]
    assert np.mean(np.abs(foot[:, 0]) > 1.0) > 0.4  # the seams are exercised
    md = vpffd.MultiresDeformer(mr, lat, backend="serial")
    r = md.deform(preserve_volume=False)
    # The rest "shift" lattice is the identity everywhere (the translation a wrapped
    # point gets back included): the frame rebuilds the mesh to rounding.
    assert np.abs(r.vertices - mesh.vertices).max() <= 1e-12 * _diag(mesh.vertices)
    assert np.abs(r.base_vertices - mr.base.vertices).max() <= 1e-12 * _diag(mesh.vertices)


def test_periodic_rigid_motion_is_exact(long_body):
    """A rotation about the periodic axis and a translation of the control points
    moves the tied copies the same way (the shift seam adds the period along x,
    which the rotation keeps), so the map is that motion everywhere."""
    mesh, mr = long_body
    lat = _short_box(mesh, "shift")
    a = np.radians(37.0)
    R = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    t = np.array([0.3, -1.2, 0.7])
    P = lat.control_points @ R.T + t
    md = vpffd.MultiresDeformer(mr, lat, backend="serial")
    n0 = md.deform(preserve_volume=False).normals.copy()
    r = md.deform(P, preserve_volume=False)
    assert np.abs(r.vertices - (mesh.vertices @ R.T + t)).max() <= 1e-12 * _diag(mesh.vertices)
    assert np.abs(r.normals - n0 @ R.T).max() < 1e-12


@pytest.mark.parametrize("seam", ["shift", "closed", "twist"])
def test_periodic_base_map_is_the_deformers(long_body, seam):
    """At the foot points the multiresolution map is the Deformer's FFD with the same
    periodic lattice: values and Jacobians (mirrored across a twist seam); the frame
    (cell-run kernel and per-point kernel alike) rebuilds S' + d N_S' from them."""
    mesh, mr = long_body
    lat = _short_box(mesh, seam)
    rng = np.random.default_rng(7)
    P = lat.control_points + 0.15 * rng.standard_normal(lat.control_points.shape)
    md = vpffd.MultiresDeformer(mr, lat, backend="serial")
    foot = mr.frame_data()["foot_points"]
    S, N = md.foot_frames(P)
    d = vpffd.Deformer(vpffd.Mesh(foot, mesh.faces), lat, backend="serial")
    diag = _diag(mesh.vertices)
    np.testing.assert_allclose(S, d.ffd(P), rtol=0, atol=1e-12 * diag)
    _, J = md._ffd.foot_values_jacobians(np.ascontiguousarray(P.reshape(-1, 3)))
    np.testing.assert_allclose(np.asarray(J).reshape(-1, 3, 3), d.jacobians(P), rtol=0, atol=1e-11)
    # The base mesh is the Deformer's FFD of the base.
    r = md.deform(P, preserve_volume=False)
    np.testing.assert_allclose(r.base_vertices, vpffd.Deformer(mr.base, lat).ffd(P), rtol=0, atol=1e-12 * diag)
    want = S + mr.displacements[:, None] * N
    np.testing.assert_allclose(r.vertices, want, rtol=0, atol=1e-11 * diag)
    X, _ = md._ffd.deform_per_point(np.ascontiguousarray(P.reshape(-1, 3)))
    np.testing.assert_allclose(X, want, rtol=0, atol=1e-11 * diag)


def test_periodic_volume_preserved(long_body):
    mesh, mr = long_body
    lat = vpffd.Lattice.around(mesh, shape=(6, 5, 5), periodic="x")
    P = vpffd.edits.squash(lat.control_points, 0.6, axis="z")
    r = vpffd.MultiresDeformer(mr, lat, backend="serial").deform(P, axes="xyz")
    assert r.base_volume_error < 1e-12


def test_to_trimesh_keeps_vertices_and_faces(long_body):
    trimesh = pytest.importorskip("trimesh")
    mesh, mr = long_body
    lat = vpffd.Lattice.around(mesh, shape=5)
    r = vpffd.MultiresDeformer(mr, lat, backend="serial").deform(vpffd.twist(lat.control_points, 40))
    t = r.to_trimesh()
    assert isinstance(t, trimesh.Trimesh)
    np.testing.assert_array_equal(t.vertices, r.vertices)
    np.testing.assert_array_equal(t.faces, mesh.faces)
    assert not np.shares_memory(t.vertices, r.vertices)
    np.testing.assert_array_equal(r.to_trimesh(base=True).vertices, r.base_vertices)
    assert t.volume == pytest.approx(r.volume, rel=1e-12)
    with pytest.raises(TypeError, match="base"):
        r.to_trimesh(base="yes")


def test_constraints_reach_their_targets(long_body):
    mesh, mr = long_body
    lat = vpffd.Lattice.around(mesh, shape=6)
    src = mr.base.vertices[np.argmax(mr.base.vertices[:, 2])]
    tgt = src + np.array([0.2, 0.0, 0.3])
    md = vpffd.MultiresDeformer(mr, lat, backend="serial")
    r = md.deform(constraints=[(src, tgt)])
    # The constraint holds for the lattice map (so for the base), the base volume is kept.
    assert r.constraint_error < 1e-9
    assert r.base_volume_error < 1e-12
    k = np.argmax(mr.base.vertices[:, 2])
    assert np.linalg.norm(r.base_vertices[k] - tgt) < 1e-9
    assert np.isnan(md.deform().constraint_error)
