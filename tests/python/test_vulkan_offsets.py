"""Moving the rest mesh by translations on the Vulkan backend (set_rest_offsets, issue 13).

Only the K offsets go to the device, which adds them to the base positions it keeps
(embed.comp with EM_OFFSET), in its reals: the moved position errs from the host's
float64 sum base + o by one more real rounding (at most U_SUM of its size), so the
parameter tau by one more term of the error bound of test_vulkan_motion's docstring
(five roundings of numbers of size at most max|u| instead of four: _check_parameter_
precision below), still under a quarter of float32's unit roundoff; the bounds of
gpu_bounds.py then hold unchanged against the CPU moved by set_rest_vertices(base + o).
The host tests each part's bounding box instead of every vertex: the same decisions
(rounding of base + o is monotonic in base), which the box-edge test checks."""
import numpy as np
import pytest

import vpffd
from gpu_bounds import U32, U_SUM, check_frame
from test_vulkan import DEVICE, edit, gpu_deformer
from test_vulkan import precision  # noqa: F401 (the fixture)
from test_vulkan_normals import check_normals
from test_rest_offsets import check_box_edge

pytestmark = pytest.mark.skipif(DEVICE is None, reason="no Vulkan backend in this build or no suitable device")


def _lattice(**kw):
    lat = vpffd.Lattice([-2.0, -2.0, -2.0], [2.0, 2.0, 2.0], shape=kw.pop("shape", (7, 7, 7)), degree=3, **kw)
    worst = 0.0
    for a in range(3):
        t = np.asarray(lat.knots[a], float)
        w = np.diff(t)
        worst = max(worst, 5 * U_SUM * np.abs(t).max() / w[w > 0].min())
    assert worst <= U32 / 4, worst
    return lat


def _two_spheres():
    s = vpffd.shapes.icosphere(3)
    V = np.concatenate([0.6 * s.vertices + [-0.8, 0.1, 0.0], 0.5 * s.vertices + [0.9, -0.2, 0.1]])
    return vpffd.Mesh(V, np.concatenate([s.faces, s.faces + s.n_vertices])), np.repeat([0, 1], s.n_vertices)


def test_offsets_equal_the_cpu_moved_by_positions(precision):
    mesh, labels = _two_spheres()
    lat = _lattice()
    P = edit(lat)
    g = gpu_deformer(mesh, lat, precision, parts=labels)
    c = vpffd.Deformer(mesh, lat, backend="serial", parts=labels)
    rest_parts = g.rest_part_volumes.copy()
    for O in (np.array([[0.3, 0.2, -0.1], [-0.1, 0.0, 0.4]]), np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.5]]),
              np.array([-0.2, 0.3, 0.1]), np.zeros(3)):
        g.set_rest_offsets(O)
        X = mesh.vertices + np.broadcast_to(O, (2, 3))[labels]
        c.set_rest_vertices(X)
        assert np.array_equal(g.rest_vertices, X)  # the host's float64 sum, made when read
        # The base's part volumes, kept exactly: the targets of every frame.
        assert np.array_equal(g.rest_part_volumes, rest_parts)
        moved = vpffd.Mesh(X, mesh.faces)
        a = g.deform(P, preserve_volume=False, normals=True)
        check_frame(a, c.deform(P, preserve_volume=False), moved, lat, cpu=c)
        for kw in (dict(), dict(axes="zx", rounds=2)):
            r = g.deform(P, **kw)
            rc = c.deform(P, target_volume=rest_parts, **kw)
            check_frame(r, rc, moved, lat, cpu=c)
            assert np.array_equal(r.target_volume, rest_parts.sum()) or r.target_volume == rest_parts.sum()
        # The CPU twin follows the offsets too.
        assert np.array_equal(g.ffd(P), c.ffd(P))


def test_offsets_equal_a_move_by_positions_on_the_device(precision):
    # One device deformer moved by offsets, one by the positions: the same frames within
    # the bounds (their positions differ by a real's rounding), the same rest normals.
    mesh = vpffd.shapes.icosphere(3)
    lat = _lattice()
    P = edit(lat)
    a = gpu_deformer(mesh, lat, precision)
    b = gpu_deformer(mesh, lat, precision)
    c = vpffd.Deformer(mesh, lat, backend="serial")
    V0 = a.rest_volume
    for o in ([0.5, -0.25, 0.2], [1.0, 0.0, 0.0], [-0.3, 0.45, -0.6]):
        a.set_rest_offsets(o)
        X = mesh.vertices + o
        b.set_rest_vertices(X)
        c.set_rest_vertices(X)
        ra, rb = a.deform(P, normals=True), b.deform(P, target_volume=V0, normals=True)
        rc = c.deform(P, target_volume=V0)
        moved = vpffd.Mesh(X, mesh.faces)
        check_frame(ra, rc, moved, lat, cpu=c)
        check_frame(rb, rc, moved, lat, cpu=c)
        assert ra.rest_volume == V0
        # The rest normals of the base serve the moved mesh (a translation keeps them):
        # the deformed ones within the derived angle bound of the CPU's exact normals.
        check_normals(ra, c, moved, lat)


def test_periodic_offsets_past_the_seam(precision):
    mesh, labels = _two_spheres()
    for seam in ("closed", "shift", "twist"):
        lat = _lattice(shape=(9, 6, 6), periodic="x", seam=seam)
        P = edit(lat)
        g = gpu_deformer(mesh, lat, precision, parts=labels)
        c = vpffd.Deformer(mesh, lat, backend="serial", parts=labels)
        for o in (1.7, 4.3, -6.1):
            O = np.array([[o, 0.0, 0.0], [0.5 * o, 0.1, 0.0]])
            g.set_rest_offsets(O)
            X = mesh.vertices + O[labels]
            c.set_rest_vertices(X)
            r = g.deform(P)
            check_frame(r, c.deform(P, target_volume=g.rest_part_volumes), vpffd.Mesh(X, mesh.faces), lat, cpu=c)


def test_moves_in_any_order_without_frames_between(precision):
    # Positions, then offsets before any frame (the positions' embedding runs first, alone),
    # offsets then positions, two offset moves in a row: each frame is of the last move.
    mesh = vpffd.shapes.icosphere(3)
    lat = _lattice()
    P = edit(lat)
    g = gpu_deformer(mesh, lat, precision)
    ref = gpu_deformer(mesh, lat, precision)

    def same(X, V_target):
        ref.set_rest_vertices(X)
        r, rr = g.deform(P), ref.deform(P, target_volume=V_target)
        c = vpffd.Deformer(vpffd.Mesh(X, mesh.faces), lat, backend="serial")
        check_frame(r, c.deform(P, target_volume=V_target), vpffd.Mesh(X, mesh.faces), lat, cpu=c)
        check_frame(rr, c.deform(P, target_volume=V_target), vpffd.Mesh(X, mesh.faces), lat, cpu=c)

    Y = 0.8 * mesh.vertices + [0.2, 0, 0]
    g.set_rest_vertices(Y)
    g.set_rest_offsets([0.0, 0.3, 0.0])  # from Y, whose embedding has not run yet
    V_y = vpffd.Deformer(vpffd.Mesh(Y, mesh.faces), lat, backend="serial").rest_volume
    assert g.rest_volume == V_y
    same(Y + [0.0, 0.3, 0.0], V_y)
    g.set_rest_offsets([0.1, 0.0, 0.0])
    g.set_rest_offsets([0.0, 0.0, -0.4])  # not added to the last: from Y again
    same(Y + [0.0, 0.0, -0.4], V_y)
    g.set_rest_offsets([0.5, 0.0, 0.0])
    g.set_rest_vertices(mesh.vertices)  # positions replace the waiting offset move
    assert np.array_equal(g.rest_vertices, mesh.vertices)
    same(mesh.vertices, vpffd.Deformer(mesh, lat, backend="serial").rest_volume)


def test_refusals_are_the_cpus_and_change_nothing(precision):
    mesh, labels = _two_spheres()
    lat = _lattice()
    P = edit(lat)
    g = gpu_deformer(mesh, lat, precision, parts=labels)
    c = vpffd.Deformer(mesh, lat, backend="serial", parts=labels)
    g.set_rest_offsets([[0.1, 0, 0], [0, 0.1, 0]])
    before = g.deform(P)
    X_before = g.rest_vertices.copy()
    for bad in ([[0, 0, 0], [0.7, 0, 0]], [[-0.9, 0, 0], [0, 0, 0]], [[0, 0, 0], [0, 0, 1e5]]):
        with pytest.raises(vpffd.InvalidInputError) as eg:
            g.set_rest_offsets(bad)
        with pytest.raises(vpffd.InvalidInputError) as ec:
            c.set_rest_offsets(bad)
        assert str(eg.value) == str(ec.value)
        assert "outside" in str(eg.value) or "away" in str(eg.value) or "lie" in str(eg.value)
    for bad in ([[np.nan, 0, 0], [0, 0, 0]], np.zeros((3, 3)), [1.0, 2.0]):
        with pytest.raises(vpffd.InvalidInputError):
            g.set_rest_offsets(bad)
    # A refused move while an offset move waits for its frame: the waiting one stands.
    g.set_rest_offsets([[0.2, 0, 0], [0, 0, 0]])
    with pytest.raises(vpffd.InvalidInputError):
        g.set_rest_vertices(mesh.vertices + [5.0, 0, 0])
    with pytest.raises(vpffd.InvalidInputError):
        g.set_rest_offsets([[0, 0, 0], [0, 9, 0]])
    X = mesh.vertices + np.array([[0.2, 0, 0], [0, 0, 0]])[labels]
    c.set_rest_vertices(X)
    r = g.deform(P)
    check_frame(r, c.deform(P, target_volume=g.rest_part_volumes), vpffd.Mesh(X, mesh.faces), lat, cpu=c)
    # Back to the first offsets: the first frame again, bit for bit.
    g.set_rest_offsets([[0.1, 0, 0], [0, 0.1, 0]])
    again = g.deform(P)
    assert np.array_equal(g.rest_vertices, X_before)
    assert np.array_equal(again.vertices, before.vertices) and again.volume == before.volume


def test_the_box_edge_is_decided_as_for_positions(precision):
    # The host tests the parts' boxes: the last offset a move by positions takes and
    # the next double (refused) are decided alike, on both faces (check_box_edge).
    mesh = vpffd.shapes.icosphere(2)
    lat = _lattice()
    check_box_edge(gpu_deformer(mesh, lat, precision), gpu_deformer(mesh, lat, precision), mesh, -2.0, 2.0,
                   1e-12 * 4.0)
