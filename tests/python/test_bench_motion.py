"""bench/python/bench_motion.py's measurement on a small scene: what each of its
columns holds (the timing itself runs only in the benchmark)."""
import numpy as np
import pytest

import vpffd
from vpffd import animate, edits


@pytest.fixture(scope="module")
def bench_motion(load_bench):
    return load_bench("bench_motion")


@pytest.mark.parametrize("preserve", [False, True])
def test_a_cpu_move_is_all_host(bench_motion, preserve):
    mesh = vpffd.shapes.icosphere(2)
    lat = vpffd.Lattice((-1.6, -1.6, -1.6), (1.6, 1.6, 1.6), shape=(6, 6, 6), degree=3)
    path = animate.PathOffset(lat, (1.0, -0.6, 0.3), speed=0.1)
    move, frame, fps, device, host = bench_motion.measure(mesh, lat, edits.twist(lat.control_points, 60), path,
                                                          "serial", None, 3, preserve)
    # No device: nothing is moved out of the frame, and the whole move is the host's.
    assert device == 0.0 and move == host
    assert host > 0 and frame > 0
    assert fps == pytest.approx(1e3 / (move + frame))
    assert np.isfinite([move, frame, fps]).all()
