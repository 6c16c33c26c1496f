"""The rest volume summed on first use: a move and a plain frame do not sum it, and
whatever reads it later (the Deformer, a result, a copy of a result) gets the very
number an eager sum gave (cpp/include/vpffd/frame/rest_volume.h, result.py)."""
import copy
import gc
import pickle

import numpy as np
import pytest

import vpffd
from vpffd import InvalidInputError

CPU = "openmp" if vpffd._core.has_openmp() else "serial"


def _scene(level=3):
    mesh = vpffd.shapes.icosphere(level)
    lat = vpffd.Lattice.around(mesh, shape=(6, 6, 6), padding=0.3)
    return mesh, lat, vpffd.twist(lat.control_points, 1.0)


def _moved(mesh, step):
    return mesh.vertices + np.array([0.04, -0.03, 0.02]) * step


def _fresh(mesh, X, lat, backend, **kw):
    return vpffd.Deformer(vpffd.Mesh(X, mesh.faces), lat, backend=backend, **kw)


def _holder(d):
    return d._vk if d._vk is not None else d._core


def _check_waits_and_equals_fresh(backend, **kw):
    mesh, lat, P = _scene()
    d = vpffd.Deformer(mesh, lat, backend=backend, **kw)
    results = []
    for step in (1, 2, 3):
        X = _moved(mesh, step)
        d.set_rest_vertices(X)
        r = d.deform(P, preserve_volume=False)
        assert not _holder(d).rest_volume_known  # neither the move nor a plain frame summed it
        results.append((r, X))
    # Read after later moves: each result has the rest volume of the mesh it deformed,
    # summed as a Deformer built on that mesh sums it (the same bits).
    for r, X in results:
        assert r.rest_volume == _fresh(mesh, X, lat, backend, **kw).rest_volume
    # A volume-preserving frame needs it (its target): summed then, and the result carries it.
    r = d.deform(P)
    assert _holder(d).rest_volume_known and "rest_volume" in r.__dict__
    fresh = _fresh(mesh, results[-1][1], lat, backend, **kw)
    assert r.rest_volume == fresh.rest_volume == d.rest_volume
    assert r.target_volume == fresh.deform(P).target_volume


def test_a_move_and_a_plain_frame_leave_the_rest_volume_for_its_first_read():
    _check_waits_and_equals_fresh(CPU)


def test_vulkan_rest_volume_waits_too():
    from test_vulkan import DEVICE, SEL
    if DEVICE is None:
        pytest.skip("no Vulkan backend in this build or no suitable device")
    _check_waits_and_equals_fresh("vulkan", device=SEL)


def test_a_result_outlives_its_deformer_and_copies_carry_the_number():
    mesh, lat, P = _scene()
    d = vpffd.Deformer(mesh, lat, backend="serial")
    X = _moved(mesh, 1)
    d.set_rest_vertices(X)
    a, b = d.deform(P, preserve_volume=False), d.deform(P, preserve_volume=False)
    want = _fresh(mesh, X, lat, "serial").rest_volume
    c = copy.deepcopy(a)  # a copy reads it first, and keeps the number
    assert "rest_volume" in c.__dict__ and "_rest_volume_source" not in c.__dict__
    ref = vpffd.Deformer(mesh, lat, backend="serial")
    ref.set_rest_vertices(X)
    del d
    gc.collect()
    # The Deformer summed what its results had not read before it went.
    assert b.rest_volume == want and c.rest_volume == want
    assert pickle.loads(pickle.dumps(b)).rest_volume == want
    assert a == copy.copy(a)
    assert ref.deform(P, preserve_volume=False).volume_change_before == b.volume_change_before


def test_rest_volume_of_is_the_sum_a_move_would_give():
    mesh, lat, _ = _scene()
    two = vpffd.shapes.icosphere(2)
    parts_mesh = vpffd.Mesh(np.vstack([two.vertices - [1.2, 0, 0], two.vertices + [1.2, 0, 0]]),
                            np.vstack([two.faces, two.faces + len(two.vertices)]))
    plat = vpffd.Lattice.around(parts_mesh, shape=(8, 5, 5), padding=0.3)
    for m, lt, parts in ((mesh, lat, None), (parts_mesh, plat, "components")):
        d = vpffd.Deformer(m, lt, backend="serial", parts=parts)
        X = _moved(m, 1)
        before = d.rest_volume
        got = d._core.rest_volume_of(X)
        assert d.rest_volume == before  # nothing moved
        d.set_rest_vertices(X)
        assert got == d.rest_volume
        if parts:  # the total is the parts' sum, two terms added once either way
            assert d.rest_part_volumes[0] + d.rest_part_volumes[1] == got
    with pytest.raises(InvalidInputError, match="rest_volume_of: 3 vertices"):
        d._core.rest_volume_of(np.zeros((3, 3)))


@pytest.mark.parametrize("radius, waits", [(1e95, True), (1e97, False)])
def test_volumes_near_double_range_are_summed_when_they_might_overflow(radius, waits):
    # The bound (rest_volume.h): F R^3 <= 1e300 with R the reach of 1000 box extents.
    # 320 faces; a sphere of radius r in a box of ~2.6 r: R^3 ~ 2e10 r^3, so 1e95 waits and
    # 1e97 is summed (and kept: its volume, ~4e291, is finite).
    mesh = vpffd.shapes.icosphere(2, radius=radius)
    lat = vpffd.Lattice.around(mesh, shape=4, degree=3)
    d = vpffd.Deformer(mesh, lat, backend="serial")
    assert d._core.rest_volume_known == (not waits)
    unit = vpffd.Deformer(vpffd.shapes.icosphere(2), vpffd.Lattice.around(vpffd.shapes.icosphere(2), shape=4))
    assert np.isfinite(d.rest_volume)
    # The scaled sphere's coordinates round once each (u = 2^-53); a cone term is a
    # product of three differences and sums, ~10 u; the 320 terms are all positive (the
    # centre is inside), so the sum adds at most 320 u relative; radius**3 and the
    # division 3 u more: ~3.7e-14 in all, under 1e-13.
    assert abs(d.rest_volume / radius**3 - unit.rest_volume) <= 1e-13 * unit.rest_volume


def test_periodic_axes_bound_by_the_vertices_own_reach():
    mesh, _, _ = _scene()
    lat = vpffd.Lattice.around(mesh, shape=(8, 6, 6), padding=0.3, periodic="x")
    P = vpffd.twist(lat.control_points, 1.0)
    d = vpffd.Deformer(mesh, lat, backend="serial")
    assert not d._core.rest_volume_known
    X = _moved(mesh, 1) + [3.0 * (lat.box_max[0] - lat.box_min[0]), 0, 0]  # whole extents along the periodic axis
    d.set_rest_vertices(X)
    r = d.deform(P, preserve_volume=False)
    assert not d._core.rest_volume_known
    assert r.rest_volume == vpffd.Deformer(vpffd.Mesh(X, mesh.faces), lat, backend="serial").rest_volume
    # Along a periodic axis any distance is taken; 1e101 away the bound is past 1e300: summed at once.
    far = mesh.vertices + [1e101, 0, 0]
    d.set_rest_vertices(far)
    assert d._core.rest_volume_known and np.isfinite(d.rest_volume)
