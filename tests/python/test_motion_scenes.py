"""The demo's moving-object scenes (vpffd.cli.motion): objects travel through a
fixed periodic deformation, each keeping its own volume."""
import numpy as np
import pytest

import vpffd
from vpffd.cli import motion


@pytest.fixture(scope="module")
def shoal():
    return motion.run_motion(motion.shoal(quick=True))


def test_every_fish_keeps_its_volume_and_the_plain_ffd_does_not(shoal):
    plain, kept = shoal.results["plain"], shoal.results["kept"]
    assert plain["volumes"].shape == (shoal.frames, 4)
    # The correction is exact to rounding: per part, a sum over its ~530 faces of
    # products of O(1) coordinates, relative error of order F u = 1e-13; 1e-10 leaves room.
    assert np.abs(kept["volumes"] / kept["rest"] - 1).max() < 1e-10
    # The tube narrows and widens by 30 %: the plain FFD changes the fish by far more than 5 %.
    change = plain["volumes"] / plain["rest"] - 1
    assert change.max() > 0.05 and change.min() < -0.05
    # Rigid motion through the rest box: the rest volumes do not change.
    np.testing.assert_allclose(plain["rest"], np.broadcast_to(plain["rest"][0], plain["rest"].shape), rtol=1e-12)


def test_the_shoal_comes_round_after_a_full_lap(shoal):
    # The ring's seam is closed: the map has period L along x, and the path wraps its
    # offset by L, so one whole lap later every fish is where it was. t is taken inside
    # a lap (not at 0, where the wrapped offset may land on either side of L).
    lap = shoal.lattice.box_max[0] - shoal.lattice.box_min[0]
    t, t_lap = 0.3, lap / shoal.path.speed
    X0, X1 = shoal.rest_positions(t), shoal.rest_positions(t + t_lap)
    d = vpffd.Deformer(shoal.mesh, shoal.lattice, parts="components")
    d.set_rest_vertices(X0)
    r0 = d.deform(shoal.control_points)
    d.set_rest_vertices(X1)
    r1 = d.deform(shoal.control_points)
    # Offsets speed*t and speed*(t + t_lap) - L round at most a few times by u of |o| <= 2L,
    # and x + o once more: 8 u L bounds the difference of the rest positions.
    assert np.abs(X1 - X0).max() <= 8 * np.finfo(float).eps * lap
    # The deformed points move by at most |J| times that (|J| = O(1) here: the ring
    # keeps lengths, the tube scales by <= 1.3), plus the frame's own rounding.
    diag = np.linalg.norm(shoal.lattice.box_max - shoal.lattice.box_min)
    assert np.abs(r1.vertices - r0.vertices).max() <= 1e-12 * diag
    np.testing.assert_allclose(r1.part_volumes, r0.part_volumes, rtol=1e-12)


def test_mobius_walkers_and_band_are_parts():
    s = motion.run_motion(motion.mobius_walk(quick=True))
    kept = s.results["kept"]
    assert kept["volumes"].shape == (s.frames, 8)  # the band and 7 walkers
    assert np.abs(kept["volumes"] / kept["rest"] - 1).max() < 1e-10
    # The band stays in place in the rest box; the walkers move along x.
    X0, X1 = s.rest_positions(0.0), s.rest_positions(0.5 * s.duration)
    assert np.array_equal(X0[~s.moving], X1[~s.moving])
    assert np.all(X1[s.moving][:, 0] != X0[s.moving][:, 0])


def test_the_scenes_move_by_part_offsets_to_their_rest_positions():
    # run_motion moves each object by its part's offset (set_rest_offsets): the rest
    # mesh it deforms is rest_positions(t) exactly (one float64 addition either way),
    # the still band included, and the rest part volumes stay those of construction.
    s = motion.mobius_walk(quick=True)
    d = vpffd.Deformer(s.mesh, s.lattice, parts="components")
    rest = d.rest_part_volumes.copy()
    for t in (0.0, 0.37 * s.duration, 0.9 * s.duration):
        O = s.part_offsets(t, d.vertex_parts)
        assert O.shape == (8, 3) and np.count_nonzero(np.abs(O).sum(axis=1)) <= 7
        d.set_rest_offsets(O)
        assert np.array_equal(d.rest_vertices, s.rest_positions(t))
        assert np.array_equal(d.rest_part_volumes, rest)
