"""Moving rest positions on the Vulkan backend (Deformer.set_rest_vertices, issue 13).

The device embeds the moved vertices itself (embed.comp: span and local parameter per
vertex, in reals from the rest positions in reals, rounded once to float32) and sorts
them by lattice cell (radix.comp, scan.comp, tiles.comp). The bounds are those of every
Vulkan test (gpu_bounds.py), which take the float32 local parameter to be within one
float32 rounding of the exact one. The device's parameter u = u0 + y du and
tau = (u - t_s) / (t_{s+1} - t_s) are computed in reals (relative rounding at most
U_SUM = 2^-44 per operation): three operations on numbers of size at most max|u|
before the subtraction, so tau errs by at most 4 U_SUM max|u| / min span width before
its float32 rounding. `_check_parameter_precision` asserts that this stays below a
quarter of float32's unit roundoff, so the bounds hold unchanged. Where u lies within
that error of a knot, the device may take the neighbouring span (tau ~ 1 there instead
of ~ 0): the spline is continuous, so the point is the same, and the basis-value bound
covers any tau in [0, 1].

A moved Vulkan Deformer and one built on the moved mesh compute every plain-FFD vertex
from the same rest position with the same operations: bit-identical. Corrected frames
may sum the cells' vertices in another order (the device slots keep the first mesh's
order), so both are compared with the CPU within the derived bounds.
"""
import numpy as np
import pytest

import vpffd
from vpffd import _core
from gpu_bounds import U32, U_SUM, check_frame
from test_vulkan import DEVICE, SEL, edit, gpu_deformer
from test_vulkan import precision  # noqa: F401 (the fixture: both precisions, float64 where the device has it)

pytestmark = pytest.mark.skipif(DEVICE is None, reason="no Vulkan backend in this build or no suitable device")


def _check_parameter_precision(lat):
    """The reals' error in tau (module docstring) is below U32 / 4."""
    worst = 0.0
    for a in range(3):
        t = np.asarray(lat.knots[a], float)
        widths = np.diff(t)
        worst = max(worst, 4 * U_SUM * np.abs(t).max() / widths[widths > 0].min())
    assert worst <= U32 / 4, worst


def _lattice(shape=(7, 7, 7), degree=3, **kw):
    lat = vpffd.Lattice([-2.0, -2.0, -2.0], [2.0, 2.0, 2.0], shape=shape, degree=degree, **kw)
    _check_parameter_precision(lat)
    return lat


def _moves(V):
    """Rest meshes along a path: translations, a squash, a shear, vertices exactly on
    the interior knot planes x, y, z in {-1, 0, 1} (icosphere vertices have zero
    coordinates; the translation by 1 puts them on the knot at 1)."""
    yield V + [1.0, 0.0, 0.0]
    yield V * [0.9, 1.1, 0.8] + [0.3, -0.25, 0.2]
    S = V.copy()
    S[:, 0] += 0.3 * S[:, 2]
    yield S - [0.4, 0.1, -0.3]
    yield V * 1.3


def _pair(mesh, lat, precision):
    """The device deformer under test and the CPU one it is checked against."""
    return gpu_deformer(mesh, lat, precision), vpffd.Deformer(mesh, lat, backend="serial")


def _move_both(g, c, X):
    """Moves both rest meshes to X."""
    g.set_rest_vertices(X)
    c.set_rest_vertices(X)


def _mesh(X, faces):
    return vpffd.Mesh(X, faces)


def _same_volume_sum(v1, v2, X, faces, origin):
    """Two float64 evaluations of the same face sum (mesh/volume.h): the same operations
    in the same order, which a compiler may still contract into fused multiply-adds
    differently in two translation units; each term then rounds differently by at most
    a few units in the last place: (n + 6) 2^-53 of the sum of the absolute terms."""
    Y = np.asarray(X, float) - origin
    F = np.asarray(faces)
    terms = np.abs(np.einsum("ij,ij->i", Y[F[:, 0]], np.cross(Y[F[:, 1]], Y[F[:, 2]]))).sum() / 6
    assert abs(v1 - v2) <= (len(F) + 6) * 2.0 ** -53 * terms, (v1, v2)


def test_moves_equal_a_fresh_deformer_and_the_cpu(precision):
    mesh = vpffd.shapes.icosphere(3)
    lat = _lattice()
    P = edit(lat)
    g, c = _pair(mesh, lat, precision)
    for X in _moves(mesh.vertices):
        X_before = X.copy()
        _move_both(g, c, X)
        assert np.array_equal(X, X_before)  # the caller's array is not modified
        assert np.array_equal(g.rest_vertices, X) and np.array_equal(g.mesh.faces, mesh.faces)
        moved = _mesh(X, mesh.faces)
        fresh = gpu_deformer(moved, lat, precision)
        # Plain FFD: the same operations on the same data, positions and normals.
        a = g.deform(P, preserve_volume=False, normals=True)
        b = fresh.deform(P, preserve_volume=False, normals=True)
        assert np.array_equal(a.vertices, b.vertices)
        assert np.array_equal(a.normals, b.normals)
        check_frame(a, c.deform(P, preserve_volume=False), moved, lat, cpu=c)
        # Volume-preserving frames (with rounds and an axis subset): against the CPU
        # Deformer moved the same way, within the derived bounds.
        for kw in (dict(), dict(axes="zx", rounds=2)):
            r, rc = g.deform(P, **kw), c.deform(P, **kw)
            check_frame(r, rc, moved, lat, cpu=c)
            rf = fresh.deform(P, **kw)
            check_frame(rf, rc, moved, lat, cpu=c)
            # The target follows the move: the rest volume is the CPU's float64 sum.
            assert r.target_volume == g.rest_volume and r.rest_volume == g.rest_volume
            _same_volume_sum(r.target_volume, rc.target_volume, X, mesh.faces, lat.center)
        _same_volume_sum(g.rest_volume, c.rest_volume, X, mesh.faces, lat.center)
        assert g.rest_volume == fresh.rest_volume  # the same code on the same data
        # The CPU-side methods see the moved mesh too (the CPU twin follows the move).
        assert np.array_equal(g.ffd(P), c.ffd(P))
        assert np.array_equal(g.jacobian_determinants(P), c.jacobian_determinants(P))


def test_reruns_are_bit_identical_and_moving_back_reproduces(precision):
    mesh = vpffd.shapes.icosphere(4)  # 2562 vertices: three blocks of the cell sort
    lat = _lattice()  # 343 control points: a cell key has two 8-bit digits
    P = edit(lat)
    g = gpu_deformer(mesh, lat, precision)
    first = g.deform(P, axes="xyz")
    X, Y = mesh.vertices * 0.8 + [0.5, -0.3, 0.1], mesh.vertices[::-1] * 0.7 - 0.2
    g.set_rest_vertices(X)
    r1 = g.deform(P, axes="xyz")
    g.set_rest_vertices(Y)  # not a mesh (reversed rows), any positions will do
    g.deform(P, preserve_volume=False)
    g.set_rest_vertices(X)
    r2 = g.deform(P, axes="xyz")
    assert np.array_equal(r1.vertices, r2.vertices) and np.array_equal(r1.offsets, r2.offsets)
    assert r1.volume == r2.volume and r1.volume_before == r2.volume_before
    g.set_rest_vertices(mesh.vertices)  # construction went through the same device path
    back = g.deform(P, axes="xyz")
    assert np.array_equal(back.vertices, first.vertices) and np.array_equal(back.offsets, first.offsets)
    assert back.volume == first.volume


@pytest.mark.parametrize("by", ["positions", "offsets"])
def test_the_frame_after_a_move_times_its_device_embedding(precision, by):
    # gpu_move_ms (bench_motion's device column) is the move's own work: present in
    # the frame that ran it, in no other, and not counted in gpu_total_ms; for a move
    # by positions and one by offsets (set_rest_offsets: its own command buffer).
    mesh = vpffd.shapes.icosphere(3)
    lat = _lattice()
    P = edit(lat)
    g = gpu_deformer(mesh, lat, precision)

    def move(scale, shift):
        if by == "positions":
            g.set_rest_vertices(mesh.vertices * scale + shift)
        else:
            g.set_rest_offsets(shift)

    g.deform(P, preserve_volume=False)
    if not g.last_timings()["has_timestamps"]:
        pytest.skip("the device's queue has no timestamps")
    assert g.last_timings()["gpu_move_ms"] == 0.0
    for frame in (dict(preserve_volume=False), dict(axes="xyz")):
        move(0.9, [0.2, -0.1, 0.05])
        g.deform(P, **frame)
        moved = g.last_timings()
        assert moved["gpu_move_ms"] > 0.0
        g.deform(P, **frame)
        assert g.last_timings()["gpu_move_ms"] == 0.0
    # Two moves without a frame between them: the device embeds the last one, once.
    move(0.8, [0.0, 0.1, 0.0])
    move(0.85, [0.1, 0.0, 0.0])
    g.deform(P)
    assert g.last_timings()["gpu_move_ms"] > 0.0


def test_many_control_points_four_sort_passes(precision):
    # 42 x 40 x 42 = 70560 control points > 2^16: four radix passes.
    mesh = vpffd.shapes.icosphere(3)
    lat = _lattice(shape=(42, 40, 42), degree=2)
    P = edit(lat)
    g, c = _pair(mesh, lat, precision)
    X = mesh.vertices * 1.2 + [0.31, -0.17, 0.05]
    _move_both(g, c, X)
    moved = _mesh(X, mesh.faces)
    fresh = gpu_deformer(moved, lat, precision)
    assert np.array_equal(g.deform(P, preserve_volume=False).vertices, fresh.deform(P, preserve_volume=False).vertices)
    check_frame(g.deform(P), c.deform(P), moved, lat, cpu=c)


def test_non_uniform_knots_and_degrees(precision):
    mesh = vpffd.shapes.icosphere(2)
    base = _lattice(shape=(5, 4, 6), degree=(2, 1, 3))
    kx = np.r_[np.zeros(3), 0.5, 0.5, np.ones(3)]  # a double interior knot along x
    lat = vpffd.Lattice(base.box_min, base.box_max, shape=base.shape, degree=base.degree,
                        knots=(kx, base.knots[1], base.knots[2]))
    _check_parameter_precision(lat)
    P = edit(lat)
    g, c = _pair(mesh, lat, precision)
    for X in _moves(mesh.vertices):  # x = 0 is the double knot
        _move_both(g, c, X)
        check_frame(g.deform(P), c.deform(P), _mesh(X, mesh.faces), lat, cpu=c)


def test_constraints_follow_the_move(precision):
    mesh = vpffd.shapes.icosphere(3)
    lat = _lattice()
    P = edit(lat)
    g, c = _pair(mesh, lat, precision)
    X = mesh.vertices * 0.9 + [0.6, -0.4, 0.3]
    _move_both(g, c, X)
    moved = _mesh(X, mesh.faces)
    cons = [(3, X[3] + [0.0, 0.0, 0.1]), (X[100] * 0.95, X[100] * 0.95 + [0.05, 0.0, 0.0])]
    for kw in (dict(constraints=cons, preserve_volume=False), dict(constraints=cons),
               dict(constraints=cons, axes="zyx", rounds=2)):
        r, rc = g.deform(P, **kw), c.deform(P, **kw)
        check_frame(r, rc, moved, lat, cpu=c)
        # Constraint rows at the moved vertex: the corrected lattice takes it to its
        # target (as the CPU's, whose constraint error is at rounding level).
        assert r.constraint_error <= max(1e-9, 10 * rc.constraint_error)


def test_outside_vertices_are_refused_like_the_cpu(precision):
    mesh = vpffd.shapes.icosphere(2)
    lat = _lattice()
    P = edit(lat)
    g, c = _pair(mesh, lat, precision)
    before = g.deform(P)
    X = mesh.vertices + [1.5, 0.0, 0.0]  # radius 1 around x = 1.5: x > 2 for some
    n_out = int((X[:, 0] > 2.0).sum())
    assert 0 < n_out < len(X)
    with pytest.raises(vpffd.InvalidInputError) as eg:
        g.set_rest_vertices(X)
    with pytest.raises(vpffd.InvalidInputError) as ec:
        c.set_rest_vertices(X)
    first = int(np.flatnonzero(X[:, 0] > 2.0)[0])
    assert str(eg.value) == str(ec.value)
    assert f"{n_out} vertices lie outside" in str(eg.value) and f"vertex {first} at" in str(eg.value)
    # Nothing changed.
    assert np.array_equal(g.rest_vertices, mesh.vertices)
    again = g.deform(P)
    assert np.array_equal(again.vertices, before.vertices) and again.volume == before.volume
    # Far away, non-finite, wrong shape.
    for bad in (mesh.vertices + [1e4, 0.0, 0.0], np.where(np.arange(len(X))[:, None] == 5, np.nan, mesh.vertices),
                mesh.vertices[:-1], mesh.vertices[:, :2]):
        with pytest.raises(vpffd.InvalidInputError):
            g.set_rest_vertices(bad)
    assert np.array_equal(g.deform(P).vertices, before.vertices)


def test_extrapolate_moves_outside(precision):
    mesh = vpffd.shapes.icosphere(2)
    lat = _lattice(shape=(6, 6, 6), degree=2)
    P = edit(lat)
    g = gpu_deformer(mesh, lat, precision, outside="extrapolate")
    X = mesh.vertices * 0.8 + [1.6, 0.0, 0.0]  # up to x = 2.4: 0.4 past the box
    g.set_rest_vertices(X)
    fresh = gpu_deformer(_mesh(X, mesh.faces), lat, precision, outside="extrapolate")
    a, b = g.deform(P, preserve_volume=False), fresh.deform(P, preserve_volume=False)
    assert np.array_equal(a.vertices, b.vertices)
    # The identity lattice maps them onto themselves (the extrapolated end pieces
    # reproduce linear functions too). The device's local parameters reach
    # T = 1 + 0.4 / span width (1) = 1.4 along x; the basis-value bound of gpu_bounds
    # ((3d + 2) 2^d u per value, d + 1 values, from |tau| <= 1) grows by T^d there,
    # since every power tau^q <= T^d. The FFD sum adds (K + 3) u of max|P - o|.
    d, K, t_x = 2, 27, 1.4
    basis = (3 * d + 2) * 2 ** d * (d + 1) * (t_x ** d + 2)  # x's values, then y's and z's
    bound = U32 * (basis + K + 3) * np.abs(lat.rest_points.reshape(-1, 3) - lat.center).max()
    rest = g.deform(lat.rest_points, preserve_volume=False).vertices
    assert np.abs(rest - X).max() <= bound, (np.abs(rest - X).max(), bound)
    # Exactly on the affine map: the CPU's identity frame of the moved mesh.
    c = vpffd.Deformer(_mesh(X, mesh.faces), lat, backend="serial", outside="extrapolate")
    assert np.abs(rest - c.ffd(lat.rest_points)).max() <= bound + 1e-12


def test_scattered_positions_exercise_the_cell_sort(precision):
    # Every vertex to a random place in the box (the faces stay: a tangled but closed
    # surface): slots land in cells in no relation to their order, many cells hold a
    # few vertices, and cell keys use both digits (12^3 control points). A wrong sort
    # or tile table would give wrong volume coefficients, hence other offsets.
    mesh = vpffd.shapes.icosphere(4)
    lat = _lattice(shape=(12, 12, 12), degree=3)
    P = edit(lat)
    rng = np.random.default_rng(7)
    g, c = _pair(mesh, lat, precision)
    for _ in range(2):
        X = rng.uniform(-1.9, 1.9, mesh.vertices.shape)
        _move_both(g, c, X)
        moved = _mesh(X, mesh.faces)
        for kw in (dict(preserve_volume=False), dict(target_volume=c.rest_volume + 0.5), dict(axes="yz", rounds=2,
                                                                                          target_volume=1.0)):
            check_frame(g.deform(P, **kw), c.deform(P, **kw), moved, lat, cpu=c)
