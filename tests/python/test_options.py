"""_core.CorrectionOptions: the one options object every backend's deform() takes."""
import numpy as np
import pytest

import vpffd
from vpffd import _core


def test_keywords_round_trip():
    cons = [(3, np.zeros(3), np.array([0.1, 0.2, 0.3])), (-1, np.array([0.5, 0.5, 0.5]), np.ones(3))]
    o = _core.CorrectionOptions(preserve_volume=False, axes="zx", rounds=3, weights=np.arange(1.0, 9.0),
                                fixed=np.array([1, 0, 0, 0, 0, 0, 0, 1], bool), constraints=cons,
                                target_volume=2.5, part_targets=[1.0, 2.0], method="csr", threads=1,
                                allow_open=True, record_timings=True)
    assert (o.preserve_volume, o.axes, o.rounds, o.method, o.threads) == (False, "zx", 3, "csr", 1)
    assert o.allow_open and o.record_timings
    np.testing.assert_array_equal(o.weights, np.arange(1.0, 9.0))
    assert list(o.fixed) == [1, 0, 0, 0, 0, 0, 0, 1]
    assert [c[0] for c in o.constraints] == [3, -1]
    np.testing.assert_array_equal(o.constraints[1][1], [0.5, 0.5, 0.5])
    assert o.target_volume == 2.5 and o.part_targets == [1.0, 2.0]
    assert "axes='zx'" in repr(o) and "constraints=2" in repr(o)


def test_defaults_are_the_papers_frame():
    o = _core.CorrectionOptions()
    assert (o.preserve_volume, o.axes, o.rounds, o.method) == (True, "xyz", 1, "traversal")
    assert o.weights is None and o.fixed is None and o.target_volume is None and o.part_targets is None
    assert o.constraints == []


def test_unknown_or_mistyped_options_are_named():
    with pytest.raises(vpffd.InvalidInputError, match="no option 'axis'.*axes"):
        _core.CorrectionOptions(axis="x")
    with pytest.raises(TypeError, match="option 'rounds' cannot take '3' \\(str\\)"):
        _core.CorrectionOptions(rounds="3")
    with pytest.raises(vpffd.InvalidInputError, match="rounds is 1099511627776; expected 1..64"):
        _core.CorrectionOptions(rounds=2**40)
    with pytest.raises(vpffd.InvalidInputError, match="axes: 'xq'"):
        _core.CorrectionOptions(axes="xq")
    with pytest.raises(vpffd.InvalidInputError, match="method"):
        _core.CorrectionOptions(method="dense")


def test_binding_deform_equals_the_public_one(sphere, lat):
    d = vpffd.Deformer(sphere, lat, backend="serial")
    P = vpffd.edits.twist(lat.control_points, 60)
    public = d.deform(P, axes="xy", rounds=2, target_volume=1.1 * d.rest_volume)
    raw = d._d.deform(np.ascontiguousarray(P.reshape(-1, 3)),
                      _core.CorrectionOptions(axes="xy", rounds=2, target_volume=1.1 * d.rest_volume, threads=1))
    np.testing.assert_array_equal(public.vertices, raw["vertices"])
    assert [s["axis"] for s in raw["steps"]] == ["x", "y", "x", "y"]


def test_frames_in_turn_each_get_their_own_options(sphere, lat):
    """Frames without per-frame arrays share options per setting (Deformer._frame_options):
    each setting, asked in any order, runs as in a Deformer that never saw another."""
    P = vpffd.edits.twist(lat.control_points, 60)
    settings = [dict(), dict(axes="xy"), dict(preserve_volume=False), dict(rounds=2), dict(method="csr"),
                dict(axes="z", rounds=3), dict(target_volume=0.9), dict(axes="xy")]
    d = vpffd.Deformer(sphere, lat, backend="serial")
    for kw in settings * 2:
        fresh = vpffd.Deformer(sphere, lat, backend="serial").deform(P, **kw)
        r = d.deform(P, **kw)
        np.testing.assert_array_equal(r.vertices, fresh.vertices)
        assert [s["axis"] for s in r.steps] == [s["axis"] for s in fresh.steps]
        assert r.volume == fresh.volume and r.method == fresh.method
    assert len(d._plain_options) == 6  # target_volume frames are built each time
    with pytest.raises(vpffd.InvalidInputError, match="axes"):
        d.deform(P, axes="xq")
    with pytest.raises(vpffd.InvalidInputError, match="axes"):
        d.deform(P, axes="xq")  # refused again: nothing kept of a refused setting
