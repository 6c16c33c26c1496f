"""Moving the rest mesh by translations (Deformer.set_rest_offsets, issue 13): each part
(or the whole mesh) to its base positions plus an offset, the paper's per-frame input
x + o(t).

What it must equal: set_rest_vertices(base + offsets), bit for bit (the same embedding,
processing order and frames) once both aim at the same volume. The one difference is
the rest volume: a move by offsets keeps the base's (a translation does not change a
closed surface's enclosed volume), where set_rest_vertices sums the moved positions,
which differ from it by rounding only: by at most twice the bound of one measurement
(_volume_error, derived in test_frame_paths.py)."""
import numpy as np
import pytest

import vpffd
from vpffd import edits, shapes
from test_frame_paths import _volume_error


def _lattice(**kw):
    return vpffd.Lattice((-1.6, -1.6, -1.6), (1.6, 1.6, 1.6), shape=(7, 6, 7), degree=3, **kw)


def _two_spheres():
    s = shapes.icosphere(3)
    V = np.concatenate([0.5 * s.vertices + [-0.6, 0.1, 0.0], 0.4 * s.vertices + [0.7, -0.2, 0.1]])
    return vpffd.Mesh(V, np.concatenate([s.faces, s.faces + s.n_vertices])), np.repeat([0, 1], s.n_vertices)


def _same_frames(a, b, P, target=None):
    """a (moved by offsets) and b (moved by positions) give the same frames, bit for bit,
    b aiming at a's rest volumes (`target`)."""
    pa, pb = a.deform(P, preserve_volume=False), b.deform(P, preserve_volume=False)
    assert np.array_equal(pa.vertices, pb.vertices)
    for kw in (dict(), dict(axes="zx", rounds=2)):
        ra = a.deform(P, **kw)
        rb = b.deform(P, target_volume=target if target is not None else a.rest_volume, **kw)
        assert np.array_equal(ra.vertices, rb.vertices), kw
        assert ra.volume == rb.volume and np.array_equal(ra.offsets, rb.offsets)


@pytest.mark.parametrize("backend", ["serial", "openmp"])
def test_offsets_equal_set_rest_vertices(backend):
    if backend == "openmp" and not vpffd._core.has_openmp():
        pytest.skip("no OpenMP in this build")
    mesh = shapes.icosphere(4)
    lat = _lattice()
    P = edits.twist(edits.squash(lat.control_points, 0.7), 60)
    a = vpffd.Deformer(mesh, lat, backend=backend)
    b = vpffd.Deformer(mesh, lat, backend=backend)
    V0 = a.rest_volume
    # Small moves (cells kept), larger ones (the processing order changes), back home.
    for o in ([1e-3, 0, 0], [0.31, -0.2, 0.17], np.array([-0.4, 0.25, 0.3]), [0.0, 0.0, 0.0]):
        O = np.array(o, float)
        O_before = O.copy()
        a.set_rest_offsets(O)
        assert np.array_equal(O, O_before)  # the caller's array is untouched
        X = mesh.vertices + O
        b.set_rest_vertices(X)
        assert np.array_equal(a.rest_vertices, X) and np.array_equal(a.mesh.vertices, X)
        # The base's volume, bit for bit; the moved sum within two measurements' rounding.
        assert a.rest_volume == V0
        assert abs(b.rest_volume - V0) <= 2 * _volume_error(b, X)
        _same_frames(a, b, P)
        assert np.array_equal(a.ffd(P), b.ffd(P))
        assert np.array_equal(a.jacobian_determinants(P), b.jacobian_determinants(P))
    # A frame keeps the base's volume: the result's rest volume is the base's too.
    r = a.deform(P)
    assert r.rest_volume == V0 and r.target_volume == V0
    assert abs(r.volume - V0) <= 1e-13 * V0


def test_offsets_do_not_accumulate_and_set_rest_vertices_sets_the_base():
    mesh = shapes.icosphere(3)
    lat = _lattice()
    P = edits.twist(lat.control_points, 45)
    d = vpffd.Deformer(mesh, lat, backend="serial")
    d.set_rest_offsets([0.2, 0, 0])
    d.set_rest_offsets([0.2, 0, 0])  # the same place, not 0.4 away
    assert np.array_equal(d.rest_vertices, mesh.vertices + [0.2, 0, 0])
    # set_rest_vertices gives a new base: offsets then move from it.
    Y = 0.8 * mesh.vertices
    d.set_rest_vertices(Y)
    V_y = d.rest_volume
    d.set_rest_offsets([0, -0.3, 0.1])
    assert np.array_equal(d.rest_vertices, Y + [0, -0.3, 0.1])
    assert d.rest_volume == V_y
    fresh = vpffd.Deformer(vpffd.Mesh(Y + [0, -0.3, 0.1], mesh.faces), lat, backend="serial")
    _same_frames(d, fresh, P)


def test_per_part_offsets_keep_every_part_volume():
    mesh, labels = _two_spheres()
    lat = _lattice()
    P = edits.twist(edits.bend(lat.control_points, 40), 70)
    a = vpffd.Deformer(mesh, lat, backend="serial", parts=labels)
    b = vpffd.Deformer(mesh, lat, backend="serial", parts=labels)
    rest_parts = a.rest_part_volumes.copy()
    for O in (np.array([[0.3, 0.2, -0.1], [-0.1, 0.0, 0.4]]), np.array([[0.0, 0.0, 0.0], [0.5, -0.3, 0.2]]),
              np.array([0.1, 0.1, 0.1])):  # (3,): every part by the same offset
        a.set_rest_offsets(O)
        X = mesh.vertices + np.broadcast_to(O, (2, 3))[labels]
        b.set_rest_vertices(X)
        assert np.array_equal(a.rest_vertices, X)
        assert np.array_equal(a.rest_part_volumes, rest_parts)
        assert np.abs(b.rest_part_volumes - rest_parts).max() <= 2 * _volume_error(b, X)
        _same_frames(a, b, P, target=rest_parts)
        r = a.deform(P)
        assert np.allclose(r.part_volumes, rest_parts, rtol=1e-13, atol=0)


def test_periodic_ring_offsets_wrap_as_positions():
    # The whales' case: a closed periodic axis, objects moved along it by more than the
    # box's extent (the embedding wraps them; the offset is not reduced here).
    mesh, labels = _two_spheres()
    for seam in ("closed", "shift", "twist"):
        lat = vpffd.Lattice((-1.6, -1.6, -1.6), (1.6, 1.6, 1.6), shape=(8, 5, 5), degree=3, periodic="x", seam=seam)
        P = edits.twist(lat.control_points, 30)
        a = vpffd.Deformer(mesh, lat, backend="serial", parts=labels)
        b = vpffd.Deformer(mesh, lat, backend="serial", parts=labels)
        for o in (1.3, 2.9, 4.1, -5.0):
            O = np.array([[o, 0.0, 0.0], [0.5 * o, 0.0, 0.05]])
            a.set_rest_offsets(O)
            b.set_rest_vertices(mesh.vertices + O[labels])
            _same_frames(a, b, P, target=a.rest_part_volumes)


@pytest.mark.parametrize("seam", ["closed", "twist"])
def test_moving_some_parts_equals_moving_all(seam):
    # Five spheres on a periodic lattice; each move changes some parts' offsets (a) or
    # rows (b) and keeps the others' bit for bit: only the changed parts are embedded
    # again (Deformer::move_parts; over half of the vertices: the whole move). Every
    # state must give the frames of a Deformer built on the moved mesh.
    s = shapes.icosphere(3)
    n = 5
    V = np.concatenate([0.3 * s.vertices + [-1.2 + 0.6 * k, 0.05 * k, -0.04 * k] for k in range(n)])
    mesh = vpffd.Mesh(V, np.concatenate([s.faces + k * s.n_vertices for k in range(n)]))
    labels = np.repeat(np.arange(n), s.n_vertices)
    lat = vpffd.Lattice((-1.6, -1.6, -1.6), (1.6, 1.6, 1.6), shape=(8, 5, 5), degree=3, periodic="x", seam=seam)
    P = edits.twist(edits.squash(lat.control_points, 0.8), 40)
    a = vpffd.Deformer(mesh, lat, backend="openmp", threads=2, parts="components")
    b = vpffd.Deformer(mesh, lat, backend="serial", parts=labels)
    O = np.zeros((n, 3))
    for step, moved in enumerate([[1], [3], [0, 4], [], [1, 2, 3], [2], [0, 1, 2, 3, 4], [4]]):
        for k in moved:
            O[k] = [0.37 * (step + 1) * (-1) ** k, 0.02 * step, -0.01 * k]
        a.set_rest_offsets(O)
        X = mesh.vertices + O[labels]
        b.set_rest_vertices(X)  # the same parts' rows change: only those are embedded too
        assert np.array_equal(a.rest_vertices, X), (step, moved)
        _same_frames(a, b, P, target=a.rest_part_volumes)
        fresh = vpffd.Deformer(vpffd.Mesh(X, mesh.faces), lat, backend="serial", parts=labels)
        assert np.array_equal(b.rest_part_volumes, fresh.rest_part_volumes)
        _same_frames(b, fresh, P, target=b.rest_part_volumes)


@pytest.mark.filterwarnings("ignore:deform. the mesh is not closed")
def test_open_mesh_sums_the_moved_positions():
    # allow_open frames keep the cone volume from the lattice centre, which a
    # translation changes: the move sums the moved positions, as set_rest_vertices does.
    s = shapes.icosphere(3)
    keep = s.vertices[s.faces].mean(axis=1)[:, 2] < 0.6  # a cap cut off
    mesh = vpffd.Mesh(s.vertices, s.faces[keep])
    assert not mesh.is_closed
    lat = _lattice()
    P = edits.twist(lat.control_points, 40)
    a = vpffd.Deformer(mesh, lat, backend="serial")
    b = vpffd.Deformer(mesh, lat, backend="serial")
    before = a.deform(P, allow_open=True).rest_volume
    a.set_rest_offsets([0.3, -0.2, 0.1])
    b.set_rest_vertices(mesh.vertices + [0.3, -0.2, 0.1])
    ra, rb = a.deform(P, allow_open=True), b.deform(P, allow_open=True)
    assert ra.rest_volume == rb.rest_volume != before
    assert np.array_equal(ra.vertices, rb.vertices)
    # The result of the frame before the move keeps the volume it had.
    assert before == vpffd.Deformer(mesh, lat, backend="serial").deform(P, allow_open=True).rest_volume


def test_results_keep_their_rest_volume_across_moves():
    mesh = shapes.icosphere(3)
    lat = _lattice()
    P = edits.twist(lat.control_points, 40)
    d = vpffd.Deformer(mesh, lat, backend="serial")
    d.set_rest_offsets([0.1, 0, 0])
    r1 = d.deform(P, preserve_volume=False)  # its rest volume not read yet
    d.set_rest_offsets([0.2, 0.1, 0])
    r2 = d.deform(P, preserve_volume=False)
    d.set_rest_vertices(0.5 * mesh.vertices)  # a new base: a new volume
    r3 = d.deform(P, preserve_volume=False)
    V0 = vpffd.Deformer(mesh, lat, backend="serial").rest_volume
    assert r1.rest_volume == r2.rest_volume == V0
    assert r3.rest_volume == vpffd.Deformer(vpffd.Mesh(0.5 * mesh.vertices, mesh.faces), lat,
                                            backend="serial").rest_volume


def test_bad_offsets_are_refused_and_change_nothing():
    mesh, labels = _two_spheres()
    lat = _lattice()
    P = edits.twist(lat.control_points, 40)
    d = vpffd.Deformer(mesh, lat, backend="serial", parts=labels)
    d.set_rest_offsets([[0.1, 0, 0], [0, 0.1, 0]])
    before = d.deform(P)
    X_before = d.rest_vertices.copy()
    c = vpffd.Deformer(mesh, lat, backend="serial", parts=labels)
    for bad, kind in (([0.1, 0.2], "shape"), (np.zeros((3, 3)), "shape"), (np.zeros((2, 2)), "shape"),
                      ([[np.nan, 0, 0], [0, 0, 0]], "finite"), ([[0, 0, 0], [0, np.inf, 0]], "finite"),
                      ([[0, 0, 0], [0.6, 0, 0]], "outside")):
        with pytest.raises(vpffd.InvalidInputError) as e:
            d.set_rest_offsets(bad)
        if kind == "outside":
            # set_rest_vertices' own count and first vertex.
            X = mesh.vertices + np.asarray(bad, float)[labels]
            with pytest.raises(vpffd.InvalidInputError) as ec:
                c.set_rest_vertices(X)
            assert str(e.value).replace("set_rest_offsets", "") == str(ec.value).replace("set_rest_vertices", "")
        elif kind == "finite":
            assert "not finite" in str(e.value)
        assert np.array_equal(d.rest_vertices, X_before)
        again = d.deform(P)
        assert np.array_equal(again.vertices, before.vertices) and again.volume == before.volume
    with pytest.raises(TypeError):
        d.set_rest_offsets(np.array([["a", "b", "c"]] * 2))
    for bad in ([[0.1, 0, 0], [0, 0.1]], None, [True, False, True]):
        with pytest.raises((TypeError, vpffd.InvalidInputError), match="set_rest_offsets"):
            d.set_rest_offsets(bad)
    with pytest.raises(vpffd.InvalidInputError, match="too far"):
        d.set_rest_offsets([[1e308, 0, 0], [0, 0, 0]])  # the sum overflows
    assert np.array_equal(d.rest_vertices, X_before)
    # Extrapolation takes them.
    e = vpffd.Deformer(mesh, lat, backend="serial", parts=labels, outside="extrapolate")
    e.set_rest_offsets([[0, 0, 0], [0.6, 0, 0]])
    f = vpffd.Deformer(mesh, lat, backend="serial", parts=labels, outside="extrapolate")
    f.set_rest_vertices(mesh.vertices + np.array([[0, 0, 0], [0.6, 0, 0]])[labels])
    _same_frames(e, f, P, target=e.rest_part_volumes)


def check_box_edge(by_offsets, by_positions, mesh, lo, hi, tol):
    """On each side along x, the last offset that `by_positions` takes for the moved
    vertices and the next double, which it refuses (found by bisection over the
    doubles, between the mesh touching the face at `lo` or `hi` and 2 `tol` past it):
    `by_offsets` must decide the same at both (two Deformers of `mesh`)."""
    def takes(o):
        try:
            by_positions.set_rest_vertices(mesh.vertices + [o, 0, 0])
            return True
        except vpffd.InvalidInputError:
            return False

    top, bottom = mesh.vertices[:, 0].max(), mesh.vertices[:, 0].min()
    for ok, bad in ((hi - top, hi + 2 * tol - top), (lo - bottom, lo - 2 * tol - bottom)):
        assert takes(ok) and not takes(bad)
        while np.nextafter(ok, bad) != bad:
            mid = 0.5 * (ok + bad)
            if mid in (ok, bad):
                mid = np.nextafter(ok, bad)
            ok, bad = (mid, bad) if takes(mid) else (ok, mid)
        by_offsets.set_rest_offsets([ok, 0, 0])
        with pytest.raises(vpffd.InvalidInputError):
            by_offsets.set_rest_offsets([bad, 0, 0])


def test_the_box_edge_is_where_set_rest_vertices_puts_it():
    mesh = shapes.icosphere(2)
    lat = _lattice()
    check_box_edge(vpffd.Deformer(mesh, lat, backend="serial"), vpffd.Deformer(mesh, lat, backend="serial"), mesh,
                   -1.6, 1.6, 1e-12 * 3.2)


def test_memory_of_a_moving_deformer_counts_the_base():
    mesh = shapes.icosphere(3)
    d = vpffd.Deformer(mesh, _lattice(), backend="serial")
    before = d.bytes_per_vertex
    d.set_rest_offsets([0.1, 0, 0])
    assert d.bytes_per_vertex >= before + 48 - 1e-9
