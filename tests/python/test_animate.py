"""Lattice animators and run_animation: exact volume at every frame, axis
restrictions, determinism, and the paper's two animated examples."""
import numpy as np
import pytest

import vpffd
from vpffd import edits, shapes
from vpffd.animate import AnimationResult, Bend, BouncingBall, Jelly, Taper, Twist, ease, run_animation

TOL = 1e-10


@pytest.fixture(scope="module")
def cube():
    m = shapes.box(8)
    return m, vpffd.Lattice.around(m, shape=(5, 5, 5), degree=3, padding=0.02)


@pytest.fixture(scope="module")
def ball():
    m = shapes.icosphere(2)
    return m, vpffd.Lattice.around(m, shape=(6, 6, 6), degree=3, padding=0.05)


def _animators(lat, mesh):
    return [Twist(lat, angle=300), Bend(lat, angle=120, ease="smooth"), Taper(lat, factor=0.3),
            BouncingBall(lat, bottom=mesh.bounds[0, 2], squash=0.6), Jelly(lat, duration=0.5)]


def test_every_animator_starts_at_rest(ball):
    mesh, lat = ball
    for a in _animators(lat, mesh):
        np.testing.assert_allclose(a(0.0), lat.rest_points, atol=1e-12, err_msg=type(a).__name__)
        assert a(a.duration).shape == lat.rest_points.shape


@pytest.mark.parametrize("axes", ["xyz", "xy", "z"])
def test_volume_kept_at_every_frame(ball, axes):
    mesh, lat = ball
    d = vpffd.Deformer(mesh, lat, backend="serial")
    for a in _animators(lat, mesh):
        r = run_animation(mesh, lat, a, frames=13, axes=axes, deformer=d)
        assert r.max_volume_error < TOL, (type(a).__name__, axes, r.max_volume_error)
        np.testing.assert_allclose(r.volumes, r.rest_volume, rtol=TOL)
        # the animation must actually change the volume for the test to mean something
        if not isinstance(a, Jelly):
            assert np.max(np.abs(r.volume_change_plain)) > 0.02, type(a).__name__


def test_axis_restriction_moves_only_chosen_axes(cube):
    mesh, lat = cube
    a = Twist(lat, angle=270)
    for axes, still in (("xy", [2]), ("z", [0, 1]), ("x", [1, 2])):
        r = run_animation(mesh, lat, a, frames=5, axes=axes)
        moved = r.corrected_points - r.control_points
        assert np.max(np.abs(moved[..., still])) == 0.0, axes
        assert np.max(np.abs(moved)) > 1e-3, axes
        assert r.axes == axes and r.preserve


def test_plain_run_is_the_plain_ffd(cube):
    mesh, lat = cube
    a = Twist(lat, angle=200)
    r = run_animation(mesh, lat, a, frames=4, preserve=False)
    d = vpffd.Deformer(mesh, lat)
    for f, t in enumerate(r.times):
        np.testing.assert_allclose(r.vertices[f], d.ffd(a(t)), atol=1e-12)
    np.testing.assert_allclose(r.volumes, r.volumes_plain, rtol=1e-14)
    np.testing.assert_array_equal(r.corrected_points, r.control_points)
    assert r.label == "plain FFD" and not r.preserve
    assert abs(r.mesh(3).volume - r.volumes[3]) < 1e-12


def test_twist_follows_the_edit(cube):
    _, lat = cube
    a = Twist(lat, angle=90, axis="x", duration=2.0)
    np.testing.assert_allclose(a(1.0), edits.twist(lat.rest_points, 45, "x"), atol=1e-12)
    np.testing.assert_allclose(a(2.0), edits.twist(lat.rest_points, 90, "x"), atol=1e-12)
    p = Twist(lat, angle=90, ease="pingpong")
    np.testing.assert_allclose(p(1.0), lat.rest_points, atol=1e-12)


def test_frame_times_and_callables(cube):
    mesh, lat = cube
    r = run_animation(mesh, lat, lambda t: edits.squash(lat.rest_points, 1 - 0.5 * t), frames=[0.0, 0.5, 1.0],
                      axes="xy", keep_vertices=False)
    assert isinstance(r, AnimationResult) and r.vertices is None
    np.testing.assert_allclose(r.volume_change_plain, [0, -0.25, -0.5], atol=1e-12)
    assert r.max_volume_error < TOL
    with pytest.raises(vpffd.InvalidInputError):
        r.mesh(0)
    with pytest.raises(vpffd.InvalidInputError):
        run_animation(mesh, lat, lambda t: lat.rest_points, frames=3)
    calls = []
    run_animation(mesh, lat, Twist(lat, 90), frames=3, progress=lambda d, n: calls.append((d, n)))
    assert calls == [(1, 3), (2, 3), (3, 3)]


def test_bad_parameters(cube):
    _, lat = cube
    with pytest.raises(vpffd.InvalidInputError):
        ease(0.5, "bouncy")
    with pytest.raises(vpffd.InvalidInputError):
        Twist(lat, 90, ease="bouncy")
    with pytest.raises(vpffd.InvalidInputError):
        Twist(lat, 90, duration=0)
    with pytest.raises(vpffd.InvalidInputError):
        Twist(lat, 90).times(0)
    with pytest.raises(vpffd.InvalidInputError):
        BouncingBall(lat, squash=-1)
    with pytest.raises(vpffd.InvalidInputError):
        Jelly(lat, kick=(1, 2))
    with pytest.raises(vpffd.InvalidInputError):
        Jelly(lat, stiffness=0)
    with pytest.raises(TypeError):
        Twist("not a lattice", 90)


def test_bad_animator_arguments_and_times(cube):
    mesh, lat = cube
    with pytest.raises(TypeError):  # was AttributeError: 'str' object has no attribute 'rest_points'
        BouncingBall("not a lattice")
    for bounces in (0, 1.5, -1):  # 1.5 was silently one bounce
        with pytest.raises(vpffd.InvalidInputError, match="bounces"):
            BouncingBall(lat, bounces=bounces)
    with pytest.raises(vpffd.InvalidInputError, match="bottom"):
        BouncingBall(lat, bottom=-np.inf)
    # a time that is not a number gave NaN control points or a bare ValueError
    for a in (BouncingBall(lat), Jelly(lat, duration=0.2), Twist(lat, 90)):
        with pytest.raises(vpffd.InvalidInputError, match="time"):
            a(float("nan"))


def test_unstable_jelly_is_reported(cube):
    _, lat = cube
    with np.errstate(over="raise", invalid="raise"):  # no overflow warnings (as errors) either
        with pytest.raises(vpffd.InvalidInputError, match="stiff"):
            Jelly(lat, stiffness=1e6, duration=0.5)(0.5)  # returned NaN control points


def test_animator_of_another_lattice(cube):
    mesh, lat = cube
    other = vpffd.Lattice.around(mesh, shape=(6, 6, 6), degree=3)
    with pytest.raises(vpffd.InvalidInputError, match="another lattice"):  # was numpy's "cannot reshape"
        run_animation(mesh, lat, Twist(other, 90), frames=2)


def test_bouncing_ball_motion(ball):
    mesh, lat = ball
    bottom = mesh.bounds[0, 2]
    a = BouncingBall(lat, bottom=bottom, squash=0.7, bounces=2)
    assert a.duration == pytest.approx(2 * a.period)
    np.testing.assert_allclose(a(a.period), lat.rest_points, atol=1e-9)  # elastic: back where it started
    # deepest flattening at mid-contact, nothing under the lattice floor
    mid = a.t_fall + 0.5 * a.t_contact
    assert a.flattening(mid) == pytest.approx(0.7)
    ts = np.linspace(0, a.period, 400)
    P = np.stack([a(t) for t in ts])
    floor = a.ground - (bottom - lat.rest_points[..., 2].min())
    assert a.ground == pytest.approx(bottom - 0.5 * a.height)  # the default drop: half the height
    assert P[..., 2].min() >= floor - 1e-12
    # continuous: small steps, no jumps at impact or take-off
    step = np.max(np.abs(np.diff(P, axis=0)), axis=(1, 2, 3, 4))
    assert step.max() < 0.05 * a.height
    # horizontal coordinates never move: the flattening is vertical only
    np.testing.assert_array_equal(P[..., :2], np.broadcast_to(lat.rest_points[..., :2], P[..., :2].shape))


def test_jelly_is_deterministic_pinned_and_damped(cube):
    _, lat = cube
    a, b = Jelly(lat, duration=1.5), Jelly(lat, duration=1.5)
    ts = np.linspace(0, 1.5, 7)
    for t in ts:
        np.testing.assert_array_equal(a(t), b(t))
    bottom = lat.rest_points[:, :, 0]
    for t in ts:
        np.testing.assert_array_equal(a(t)[:, :, 0], bottom)
        assert np.all(np.isfinite(a(t)))
    amp = [np.abs(a(t) - lat.rest_points).max() for t in np.linspace(0, 1.5, 61)]
    assert max(amp) > 0.02
    assert max(amp[-10:]) < max(amp)  # damping: the wobble dies down
    still = Jelly(lat, kick=(0, 0, 0), duration=0.5)
    np.testing.assert_allclose(still(0.5), lat.rest_points, atol=1e-12)


def test_paper_twisting_cube_figure():
    """Figure 6: box(32) has the paper's 6,146 vertices; twisted to 345 degrees in
    a 5x5x5 cubic lattice the plain FFD loses 66 % at the last frame."""
    from vpffd.cli.demo import CUBE_TWIST_DEG, twisting_cube
    s = twisting_cube()
    assert s.mesh.n_vertices == 6146 and CUBE_TWIST_DEG == 345
    d = vpffd.Deformer(s.mesh, s.lattice, backend="serial")
    plain = run_animation(s.mesh, s.lattice, s.animator, frames=[s.animator.duration], preserve=False, deformer=d)
    assert -plain.volume_change_plain[-1] == pytest.approx(0.66, abs=0.005)
    for axes in ("xy", "z"):
        r = run_animation(s.mesh, s.lattice, s.animator, frames=[s.animator.duration], axes=axes, deformer=d)
        assert r.max_volume_error < TOL


def test_paper_bouncing_ball_figure():
    """Figure 1: 28 %, 51 %, 64 % lost at three frames of the flattening; ours
    are frames 12, 14, 16 of 41 and lose 29.7 %, 50.1 %, 63.6 %."""
    from vpffd.cli.demo import bouncing_ball
    s = bouncing_ball()
    assert s.keyframes == [0, 12, 14, 16] and s.frames == 41
    r = run_animation(s.mesh, s.lattice, s.animator, frames=[s.animator.times(41)[f] for f in s.keyframes],
                      axes="xy", keep_vertices=False)
    np.testing.assert_allclose(-r.volume_change_plain[1:], [0.297, 0.501, 0.636], atol=0.002)
    assert r.max_volume_error < TOL


def test_bad_axes_refused_at_construction(cube):
    """A bad axis (or toward == axis) was accepted and failed only at the first frame."""
    _, lat = cube
    for make, match in ((lambda: Twist(lat, 90, axis="w"), "axis"), (lambda: Taper(lat, axis=5), "axis"),
                        (lambda: Twist(lat, 90, axis=[2]), "axis"), (lambda: Taper(lat, axis=True), "axis"),
                        (lambda: Bend(lat, 30, axis="q"), "axis"), (lambda: Bend(lat, 30, toward="w"), "toward"),
                        (lambda: Bend(lat, 30, axis="z", toward="z"), "toward"),
                        (lambda: Bend(lat, 30, axis="x", toward=0), "toward"),
                        (lambda: Jelly(lat, axis="up"), "axis")):
        with pytest.raises(vpffd.InvalidInputError, match=match):
            make()
    assert Bend(lat, 30, axis="x", toward=1)(1.0).shape == lat.rest_points.shape  # 0..2 still accepted


def test_non_numeric_parameters_name_the_parameter(cube):
    """Strings and None gave numpy's "ufunc 'isfinite' not supported" TypeError,
    naming nothing."""
    _, lat = cube
    for make, name in ((lambda: BouncingBall(lat, drop="a"), "drop"),
                       (lambda: BouncingBall(lat, squash=None), "squash"),
                       (lambda: BouncingBall(lat, stretch="x"), "stretch"),
                       (lambda: BouncingBall(lat, gravity=[1, 2]), "gravity"),
                       (lambda: BouncingBall(lat, bottom="low"), "bottom"),
                       (lambda: Jelly(lat, damping="x"), "damping"), (lambda: Jelly(lat, stiffness=None), "stiffness"),
                       (lambda: Jelly(lat, dt="0.01"), "dt"), (lambda: Jelly(lat, kick="abc"), "kick"),
                       (lambda: Twist(lat, angle="a"), "angle"), (lambda: Taper(lat, factor=None), "factor"),
                       (lambda: Twist(lat, 90, duration="2"), "duration")):
        with pytest.raises(TypeError, match=name):
            make()
    with pytest.raises(vpffd.InvalidInputError, match="angle"):  # NaN control points at every frame
        Twist(lat, angle=np.nan)
    # numpy scalars are numbers
    assert Twist(lat, np.float32(90), duration=np.int64(2)).duration == 2.0


def test_run_animation_preserve_must_be_a_bool(cube):
    mesh, lat = cube
    with pytest.raises(TypeError, match="preserve"):  # "no" was truthy: silently preserved
        run_animation(mesh, lat, Twist(lat, 90), frames=2, preserve="no")
    assert not run_animation(mesh, lat, Twist(lat, 90), frames=2, preserve=np.bool_(False)).preserve


def test_animation_mesh_frame_range(cube):
    mesh, lat = cube
    r = run_animation(mesh, lat, Twist(lat, 90), frames=4, preserve=False)
    np.testing.assert_array_equal(r.mesh(-1).vertices, r.vertices[3])
    np.testing.assert_array_equal(r.mesh(np.int64(2)).vertices, r.vertices[2])
    for bad in (4, -5, 100):  # was numpy's "index 4 is out of bounds for axis 0"
        with pytest.raises(IndexError, match=r"0\.\.3"):
            r.mesh(bad)


def test_open_mesh_volume_is_nan_and_documented(cube):
    mesh, lat = cube
    open_mesh = vpffd.Mesh(mesh.vertices, mesh.faces[:-2])
    r = run_animation(open_mesh, lat, Twist(lat, 90), frames=2, preserve=False)
    assert np.isnan(r.rest_volume) and np.isnan(r.max_volume_error)
    for doc in (AnimationResult.__doc__, AnimationResult.volume_change.__doc__,
                AnimationResult.max_volume_error.__doc__):
        doc = " ".join(doc.split())
        assert "open mesh" in doc and "NaN" in doc
