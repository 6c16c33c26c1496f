"""bench/python/bench_motion.py's measurement on a small scene: what each of its
columns holds (the timing itself runs only in the benchmark)."""
import numpy as np
import pytest

import vpffd
from vpffd import animate, edits


@pytest.fixture(scope="module")
def bench_motion(load_bench):
    return load_bench("bench_motion")


@pytest.mark.parametrize("how", ["positions", "offsets"])
@pytest.mark.parametrize("preserve", [False, True])
def test_a_cpu_move_is_all_host(bench_motion, preserve, how):
    mesh = vpffd.shapes.icosphere(2)
    lat = vpffd.Lattice((-1.6, -1.6, -1.6), (1.6, 1.6, 1.6), shape=(6, 6, 6), degree=3)
    path = animate.PathOffset(lat, (1.0, -0.6, 0.3), speed=0.1)
    move, frame, fps, device, host = bench_motion.measure(mesh, lat, edits.twist(lat.control_points, 60), path,
                                                          "serial", None, 3, preserve, how)
    # No device: nothing is moved out of the frame, and the whole move is the host's.
    assert device == 0.0 and move == host
    assert host > 0 and frame > 0
    assert fps == pytest.approx(1e3 / (move + frame))
    assert np.isfinite([move, frame, fps]).all()


def test_one_of_many_moves_part_zero_alone(bench_motion):
    # The drag scene's path: part 0 follows the path, the others stay; both kinds of move
    # give the same rest mesh, and measure runs it with parts on plain frames too.
    s = vpffd.shapes.icosphere(2)
    mesh = vpffd.Mesh(np.concatenate([0.4 * s.vertices - [0.7, 0, 0], 0.4 * s.vertices + [0.7, 0, 0]]),
                      np.concatenate([s.faces, s.faces + s.n_vertices]))
    parts = np.repeat([0, 1], s.n_vertices)
    lat = vpffd.Lattice((-1.6, -1.6, -1.6), (1.6, 1.6, 1.6), shape=(6, 6, 6), degree=3)
    path = bench_motion.OneOfMany(animate.PathOffset(lat, (0.0, 1.0, 0.0), speed=0.1).offset, parts)
    O = path.offset(2.0)
    assert O.shape == (2, 3) and np.allclose(O[0], [0, 0.2, 0]) and not O[1].any()
    X = path.positions(mesh.vertices, 2.0)
    assert np.array_equal(X, mesh.vertices + O[parts])
    a = vpffd.Deformer(mesh, lat, backend="serial", parts="components")
    a.set_rest_offsets(O)
    assert np.array_equal(a.rest_vertices, X)
    for preserve in (False, True):
        for how in ("positions", "offsets"):
            move, frame, fps, device, host = bench_motion.measure(mesh, lat, edits.twist(lat.control_points, 60),
                                                                  path, "serial", None, 3, preserve, how)
            assert move == host > 0 and frame > 0


def test_bench_move_prints_one_row_per_thread_count(load_bench, capsys, monkeypatch):
    bench_move = load_bench("bench_move")
    monkeypatch.setattr("sys.argv", ["bench_move.py", "--level", "2", "--moves", "2"])
    bench_move.main()
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| ") and line[2].isdigit()]
    assert len(rows) == (2 if vpffd._core.has_openmp() else 1)
    for row in rows:
        py, core, off = (float(x) for x in row.strip("| ").split("|")[1:4])
        assert py > 0 and core > 0 and off > 0


def test_an_unknown_move_is_refused(bench_motion):
    mesh = vpffd.shapes.icosphere(1)
    lat = vpffd.Lattice((-1.6, -1.6, -1.6), (1.6, 1.6, 1.6), shape=(4, 4, 4), degree=2)
    with pytest.raises(ValueError, match="move"):
        bench_motion.measure(mesh, lat, lat.control_points, animate.PathOffset(lat, "x", speed=0.1), "serial",
                             None, 2, False, "teleport")


def test_bench_move_parts_prints_each_case(load_bench, capsys, tmp_path):
    # The table's rows on a tiny shoal: per thread count, offsets (1, 1 with the whole
    # move forced, 4 of 4) and positions (1, 4 of 4), each with a finite cost (printed
    # to 0.01 ms: a fast machine may print 0.00 for this shoal).
    bench = load_bench("bench_move_parts")
    md = tmp_path / "t.md"
    bench.main(["--fish", "4", "--fish-size", "24", "16", "--frames", "2", "--md", str(md)])
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| ") and line[2].isdigit()]
    assert len(rows) == 5 * (2 if vpffd._core.has_openmp() else 1)
    assert sum("whole move forced" in r for r in rows) == len(rows) // 5
    for row in rows:
        move, frame = (float(x) for x in row.strip("| ").split("|")[3:5])
        assert move >= 0 and frame >= 0
    assert md.read_text().count("\n| ") == len(rows) + 1
