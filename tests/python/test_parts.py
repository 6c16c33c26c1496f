"""Several objects in one mesh, each keeping its own volume (Deformer(parts=...)),
and rest meshes that move through the lattice (Deformer.set_rest_vertices)."""
import numpy as np
import pytest

import vpffd
from vpffd import edits, shapes

InvalidInputError = vpffd.InvalidInputError
SolverError = vpffd.SolverError


def spheres(count, subdivisions=2):
    """`count` unit spheres 3 apart along x as one mesh, and their labels (0, 10, 20...)."""
    s = shapes.icosphere(subdivisions)
    nv = s.n_vertices
    V = np.concatenate([s.vertices + [3.0 * i, 0, 0] for i in range(count)])
    F = np.concatenate([s.faces + i * nv for i in range(count)])
    labels = np.repeat(10 * np.arange(count), nv)
    return vpffd.Mesh(V, F), labels


def twisted(lat, angle=np.pi):
    return edits.twist(lat.control_points, angle, axis="z")


# Relative volume error of a corrected part. A part's volume is a sum of ~F_k face
# terms (320 per sphere here), each rounded to about u |term| with terms up to about
# the part's volume; the last axis step lands on the target to a few ulps of it and the
# measured sum adds ~F_k u: a few 1e-14. 1e-11 leaves three orders of margin, on any
# machine and compiler (the sums are fixed-order double precision).
VOLUME_TOL = 1e-11


@pytest.mark.parametrize("count", [2, 3])
@pytest.mark.parametrize("edit", ["twist", "squash"])
def test_every_part_keeps_its_volume(count, edit):
    mesh, labels = spheres(count)
    lat = vpffd.Lattice.around(mesh, shape=(8, 5, 5))
    d = vpffd.Deformer(mesh, lat, parts=labels, backend="serial")
    assert d.n_parts == count
    assert list(d.part_labels) == list(10 * np.arange(count))
    rest = d.rest_part_volumes
    single = vpffd.shapes.icosphere(2).volume
    # Translated copies of one sphere: the same volume up to the face sums' rounding.
    assert np.allclose(rest, single, rtol=1e-12, atol=0)
    P = twisted(lat) if edit == "twist" else edits.squash(lat.control_points, 0.5, axis="z")
    r = d.deform(P)
    assert r.part_volumes.shape == (count,)
    rel = np.abs(r.part_volumes - rest) / rest
    assert rel.max() <= VOLUME_TOL
    # The plain FFD did change each part (the test is not vacuous).
    assert (np.abs(r.part_volumes_before - rest) / rest).min() > 1e-4
    assert np.array_equal(r.part_target_volumes, rest)
    assert abs(r.volume - rest.sum()) <= VOLUME_TOL * rest.sum()
    assert abs(r.part_volumes.sum() - r.volume) <= VOLUME_TOL * r.volume


def test_parts_trade_volume_without_parts():
    # A squash of one side only: with one volume row the other sphere grows to pay for it.
    mesh, labels = spheres(2)
    lat = vpffd.Lattice.around(mesh, shape=(8, 5, 5))
    P = lat.control_points.copy()
    P[:3, :, :, 2] *= 0.5  # squash the left third of the lattice (sphere 0) along z
    part = vpffd.Deformer(mesh, lat, parts=labels, backend="serial")
    whole = vpffd.Deformer(mesh, lat, backend="serial")
    rw = whole.deform(P)
    rp = part.deform(P)
    sub = vpffd.Mesh(rw.vertices[labels == 10], mesh.faces[mesh.n_faces // 2:] - mesh.n_vertices // 2)
    rest1 = part.rest_part_volumes[1]
    assert abs(sub.volume - rest1) / rest1 > 1e-3  # whole-mesh correction moved volume into sphere 1
    assert abs(rp.part_volumes[1] - rest1) / rest1 <= VOLUME_TOL


def test_components_equal_labels_and_targets_per_part():
    mesh, labels = spheres(3)
    lat = vpffd.Lattice.around(mesh, shape=(9, 5, 5))
    a = vpffd.Deformer(mesh, lat, parts=labels, backend="serial")
    b = vpffd.Deformer(mesh, lat, parts="components", backend="serial")
    assert list(b.part_labels) == [0, 1, 2]
    assert np.array_equal(a.vertex_parts, b.vertex_parts)
    P = twisted(lat, 0.75 * np.pi)
    assert np.array_equal(a.deform(P).vertices, b.deform(P).vertices)
    targets = a.rest_part_volumes * [1.0, 1.2, 0.8]
    r = a.deform(P, target_volume=targets, rounds=2)
    assert (np.abs(r.part_volumes - targets) / targets).max() <= VOLUME_TOL
    assert r.target_volume == pytest.approx(targets.sum(), rel=1e-15)
    with pytest.raises(InvalidInputError, match="one target volume per part"):
        a.deform(P, target_volume=float(targets.sum()))
    with pytest.raises(InvalidInputError, match="one volume per part"):
        a.deform(P, target_volume=targets[:2])
    with pytest.raises(InvalidInputError, match="finite"):
        a.deform(P, target_volume=[1.0, np.nan, 1.0])


def test_point_constraints_together_with_parts():
    mesh, labels = spheres(2)
    lat = vpffd.Lattice.around(mesh, shape=(8, 6, 6))
    d = vpffd.Deformer(mesh, lat, parts=labels, backend="serial")
    v0, v1 = 0, mesh.n_vertices // 2 + 5
    t0 = mesh.vertices[v0] + [0, 0.2, 0.1]
    t1 = mesh.vertices[v1] + [-0.1, 0, 0.15]
    r = d.deform(edits.squash(lat.control_points, 0.7, axis="z"), constraints=[(v0, t0), (v1, t1)])
    # Constraint rows are O(1) basis values on O(1) coordinates: rounding level.
    assert r.constraint_error <= 1e-12
    assert np.abs(r.vertices[v0] - t0).max() <= 1e-12
    assert (np.abs(r.part_volumes - d.rest_part_volumes) / d.rest_part_volumes).max() <= VOLUME_TOL
    # Constraints alone (no volume rows) still report each part's volume.
    q = d.deform(lat.control_points, preserve_volume=False, constraints=[(v0, t0)])
    assert q.part_volumes.shape == (2,) and q.part_target_volumes is None


def test_fixed_points_that_pin_a_part_are_named():
    mesh, labels = spheres(2)
    lat = vpffd.Lattice.around(mesh, shape=(8, 5, 5))
    d = vpffd.Deformer(mesh, lat, parts=labels, backend="serial")
    B = d.basis_matrix()
    touches_1 = np.asarray(abs(B[labels == 10]).sum(axis=0)).ravel() > 0
    with pytest.raises(SolverError, match="part 1"):
        d.deform(twisted(lat), fixed=touches_1)


def test_bad_parts():
    mesh, labels = spheres(2)
    lat = vpffd.Lattice.around(mesh, shape=(8, 5, 5))
    with pytest.raises(InvalidInputError, match="one per vertex"):
        vpffd.Deformer(mesh, lat, parts=labels[:-1], backend="serial")
    with pytest.raises(TypeError, match="integer labels"):
        vpffd.Deformer(mesh, lat, parts=labels.astype(float), backend="serial")
    with pytest.raises(InvalidInputError, match="components"):
        vpffd.Deformer(mesh, lat, parts="objects", backend="serial")
    mixed = labels.copy()
    mixed[mesh.faces[7, 1]] = 99
    with pytest.raises(InvalidInputError, match=r"face \d+ joins vertices of different parts \(vertex \d+ has label"):
        vpffd.Deformer(mesh, lat, parts=mixed, backend="serial")
    # Sphere 1 with one face removed is open: 3 boundary edges.
    open_mesh = vpffd.Mesh(mesh.vertices, mesh.faces[:-1])
    with pytest.raises(InvalidInputError, match=r"part 1 \(label 10\) is open \(3 boundary edges\)"):
        vpffd.Deformer(open_mesh, lat, parts=labels, backend="serial")
    with pytest.raises(InvalidInputError, match="open"):
        vpffd.Deformer(open_mesh, lat, parts="components", backend="serial")
    d = vpffd.Deformer(mesh, lat, parts=labels, backend="serial")
    with pytest.raises(InvalidInputError, match="csr"):
        d.deform(twisted(lat), method="csr")
    before = labels.copy()
    vpffd.Deformer(mesh, lat, parts=labels, backend="serial")
    assert np.array_equal(labels, before)


# Parts on backend "vulkan": tests/python/test_vulkan_parts.py.


# --- moving rest positions -----------------------------------------------------------

def _moved(V, step):
    return V + np.array([0.08 * step, -0.05 * step, 0.03 * step])


@pytest.mark.parametrize("with_parts", [False, True])
def test_set_rest_vertices_equals_a_fresh_deformer(with_parts):
    mesh, labels = spheres(2)
    lat = vpffd.Lattice.around(mesh, shape=(8, 6, 6), padding=0.3)
    parts = labels if with_parts else None
    d = vpffd.Deformer(mesh, lat, parts=parts, backend="openmp" if vpffd._core.has_openmp() else "serial")
    P = twisted(lat, 0.5 * np.pi)
    first = d.deform(P)
    for step in (1, 2, 3):  # several moves in a row
        X = _moved(mesh.vertices, step)
        X_before = X.copy()
        d.set_rest_vertices(X)
        assert np.array_equal(X, X_before)  # the caller's array is not modified
        assert np.array_equal(d.rest_vertices, X) and np.array_equal(d.mesh.vertices, X)
        assert d.mesh.faces is not None and np.array_equal(d.mesh.faces, mesh.faces)
        fresh = vpffd.Deformer(vpffd.Mesh(X, mesh.faces), lat, parts=parts, backend=d.backend)
        a, b = d.deform(P), fresh.deform(P)
        # The moved Deformer runs the very same operations on the same data in the same
        # order (embedding, cell order, faces, sums) as the fresh one: bit-identical
        # results, stronger than the 1e-12 the issue asks for.
        assert np.array_equal(a.vertices, b.vertices)
        assert np.array_equal(a.offsets, b.offsets)
        assert a.volume == b.volume and a.volume_before == b.volume_before
        assert d.rest_volume == fresh.rest_volume
        if with_parts:
            assert np.array_equal(a.part_volumes, b.part_volumes)
            assert np.array_equal(d.rest_part_volumes, fresh.rest_part_volumes)
        assert (d.face_matrix() != fresh.face_matrix()).nnz == 0
        assert np.array_equal(d.ffd(P), fresh.ffd(P))
        # The moved mesh's volume is kept too.
        assert abs(a.volume - d.rest_volume) <= VOLUME_TOL * d.rest_volume
    d.set_rest_vertices(mesh.vertices)  # moving back reproduces the original frame
    back = d.deform(P)
    assert np.array_equal(back.vertices, first.vertices) and back.volume == first.volume


def test_rest_vertex_constraints_follow_the_move():
    mesh, _ = spheres(1, 3)
    lat = vpffd.Lattice.around(mesh, shape=(6, 6, 6), padding=0.4)
    d = vpffd.Deformer(mesh, lat, backend="serial")
    X = _moved(mesh.vertices, 2)
    d.set_rest_vertices(X)
    # An identity lattice maps the new rest vertices onto themselves (the embedding moved);
    # the FFD reproduces linear maps to rounding of O(1) coordinates.
    assert np.abs(d.ffd() - X).max() <= 1e-13
    target = X[3] + [0, 0, 0.1]
    r = d.deform(constraints=[(3, target)], preserve_volume=False)
    assert np.abs(r.vertices[3] - target).max() <= 1e-12


def test_set_rest_vertices_bad_input():
    mesh, _ = spheres(1)
    lat = vpffd.Lattice.around(mesh, shape=(5, 5, 5))
    d = vpffd.Deformer(mesh, lat, backend="serial")
    V0 = d.rest_volume
    X = mesh.vertices.copy()
    X[[4, 9, 11], 0] += 10.0
    with pytest.raises(InvalidInputError, match="3 vertices lie outside the lattice box.*the first is vertex 4"):
        d.set_rest_vertices(X)
    assert d.rest_volume == V0 and np.array_equal(d.rest_vertices, mesh.vertices)  # unchanged
    with pytest.raises(InvalidInputError, match="expected shape"):
        d.set_rest_vertices(X[:, :2])
    with pytest.raises(InvalidInputError, match="rows"):
        d.set_rest_vertices(X[:-1])
    bad = mesh.vertices.copy()
    bad[6, 2] = np.nan
    with pytest.raises(InvalidInputError, match=r"vertex 6 has a non-finite coordinate \(.*nan\)"):
        d.set_rest_vertices(bad)
    bad[6, 2] = -np.inf
    with pytest.raises(InvalidInputError, match=r"vertex 6 has a non-finite coordinate \(.*-inf\)"):
        d.set_rest_vertices(bad)
    assert d.rest_volume == V0 and np.array_equal(d.rest_vertices, mesh.vertices)  # still unchanged
    e = vpffd.Deformer(mesh, lat, backend="serial", outside="extrapolate")
    e.set_rest_vertices(mesh.vertices + [0.3, 0, 0])  # outside the box, extrapolated
    # A translation keeps the volume: both sums round by ~F u |term| (320 faces, terms < 1).
    assert abs(e.rest_volume - V0) <= 1e-12 * V0
    assert abs(e.deform(twisted(lat)).volume - V0) <= VOLUME_TOL * V0


# set_rest_vertices on backend "vulkan": tests/python/test_vulkan_motion.py.


def test_a_part_that_leaves_the_lattice_is_named():
    mesh, labels = spheres(3)
    lat = vpffd.Lattice.around(mesh, shape=(6, 5, 5))
    d = vpffd.Deformer(mesh, lat, backend="serial", parts=labels)
    X = mesh.vertices.copy()
    X[labels == 20] += [2.0, 0, 0]  # the third sphere swims out of the box, partly
    with pytest.raises(InvalidInputError, match=r"parts outside: part 2 \(label 20\): \d+ of its 162 vertices$"):
        d.set_rest_vertices(X)
    assert np.array_equal(d.rest_vertices, mesh.vertices)  # unchanged
    # Without parts the error is embed's alone.
    e = vpffd.Deformer(mesh, lat, backend="serial")
    with pytest.raises(InvalidInputError) as err:
        e.set_rest_vertices(X)
    assert "parts outside" not in str(err.value)


@pytest.mark.parametrize("periodic", [False, True])
def test_moves_that_keep_or_change_the_order_equal_a_fresh_deformer(periodic):
    # set_rest_vertices skips the faces and fans when no vertex changes cell (a tiny
    # move) and carries them over from the previous order otherwise; both must give a
    # fresh Deformer's frame bit for bit, with parts, and on a periodic lattice where
    # the spheres cross the seam.
    mesh, labels = spheres(2)
    if periodic:
        lat = vpffd.Lattice((-1.5, -1.5, -1.5), (5.5, 1.5, 1.5), shape=(8, 4, 4), degree=3, periodic="x",
                            seam="shift")
        P = edits.squash(lat.control_points, 0.7)
        steps = [np.array([1e-9, 0, 0])] + [np.array([1.3 * k, 0.02, -0.02]) for k in (1, 2, 3, 4)]
    else:
        lat = vpffd.Lattice.around(mesh, shape=(8, 6, 6), padding=0.4)
        P = twisted(lat, 0.5 * np.pi)
        steps = [np.array([1e-9, -1e-9, 1e-9])] + [np.array([0.07, -0.05, 0.03]) * k for k in (1, 2, 3)]
    d = vpffd.Deformer(mesh, lat, parts=labels, backend="openmp" if vpffd._core.has_openmp() else "serial")
    for off in steps:
        X = mesh.vertices + off
        d.set_rest_vertices(X)
        fresh = vpffd.Deformer(vpffd.Mesh(X, mesh.faces), lat, parts=labels, backend=d.backend)
        a, b = d.deform(P), fresh.deform(P)
        assert np.array_equal(a.vertices, b.vertices)
        assert np.array_equal(a.part_volumes, b.part_volumes)
        assert np.array_equal(d.rest_part_volumes, fresh.rest_part_volumes)
        assert (d.face_matrix() != fresh.face_matrix()).nnz == 0
