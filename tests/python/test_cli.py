"""The ``vpffd`` command end to end in a temporary folder: files written, exit
status, and one-line errors (never a traceback) for bad files and arguments."""
import importlib.util
import os
import subprocess
import sys

import numpy as np
import pytest

import vpffd
from vpffd import shapes
from vpffd.cli.main import main

# What the compiled core was built with (the Python modules always ship).
HAS_IO = vpffd._core.has_openmesh
HAS_RENDER = vpffd._core.has_embree and importlib.util.find_spec("PIL") is not None
needs_io = pytest.mark.skipif(not HAS_IO, reason="this build has no OpenMesh (mesh files)")


def _run(*args, cwd):
    """``python -m vpffd ARGS`` in a subprocess: (status, stdout, stderr)."""
    p = subprocess.run([sys.executable, "-m", "vpffd", *map(str, args)], cwd=cwd, capture_output=True, text=True,
                       timeout=120)
    return p.returncode, p.stdout, p.stderr


def _write_obj(path, mesh):
    with open(path, "w") as fh:
        for v in mesh.vertices:
            fh.write("v %.17g %.17g %.17g\n" % tuple(v))
        for f in mesh.faces + 1:
            fh.write(f"f {f[0]} {f[1]} {f[2]}\n")
    return path


def _one_line_error(err, prog):
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(prog), err
    assert ": error: " in lines[0], err
    assert "Traceback" not in err
    return lines[0]


@pytest.mark.parametrize("cmd", [[], ["demo"], ["deform"], ["info"], ["bench"]])
def test_help_everywhere(cmd, capsys):
    with pytest.raises(SystemExit) as e:
        main([*cmd, "--help"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: vpffd")
    assert len(out.splitlines()) > 5


def test_demo_end_to_end(tmp_path):
    out = tmp_path / "demo"
    status, stdout, stderr = _run("demo", "--quick", "--out", out, cwd=tmp_path)
    assert status == 0, stderr
    assert "Traceback" not in stderr
    for s in ("Twisting cube", "Bouncing ball", "plain FFD", "keep xy", "keep z", "key frames"):
        assert s in stdout
    assert (out / "volume.png").stat().st_size > 10_000
    rows = (out / "volume.csv").read_text().splitlines()
    assert rows[0].startswith("scene,frame") and len(rows) == 1 + 4 * (9 + 21)
    # every preserved frame exact, read back from the CSV
    import csv
    for r in csv.DictReader((out / "volume.csv").open()):
        if r["variant"] != "plain":
            assert abs(float(r["relative_change"])) < 1e-10
    # every object of the moving-object scenes keeps its volume; the plain FFD changes them
    assert "Shoal" in stdout and "Moebius walk" in stdout
    motion = list(csv.DictReader((out / "motion_volume.csv").open()))
    assert len(motion) == 2 * 10 * 4 + 2 * 10 * 8  # variants x frames x objects (4 fish; band + 7 walkers)
    kept = [abs(float(r["relative_change"])) for r in motion if r["variant"] == "kept"]
    plain = [abs(float(r["relative_change"])) for r in motion if r["variant"] == "plain" and r["scene"] == "shoal"]
    assert max(kept) < 1e-10 and max(plain) > 0.05
    assert (out / "motion_volume.png").stat().st_size > 10_000
    if HAS_RENDER:
        from PIL import Image
        for scene, frames in (("twisting_cube", 9), ("bouncing_ball", 21)):
            pngs = sorted((out / scene).glob("frame_*.png"))
            assert len(pngs) == frames
            gif = Image.open(out / f"{scene}.gif")
            assert gif.n_frames == frames and gif.size == (4 * 320, 240)
            assert (out / f"{scene}_keyframes.png").exists()
        for scene in ("shoal", "mobius_walk"):  # the moving-object scenes: plain | kept
            gif = Image.open(out / f"{scene}.gif")
            assert gif.n_frames == 10 and gif.size == (2 * 320, 240)
    else:
        assert "no frames or GIFs written" in stdout
        assert not list(out.glob("*.gif"))


def test_demo_no_render(tmp_path, capsys):
    assert main(["demo", "--quick", "--no-render", "--out", str(tmp_path)]) == 0
    assert "rendering switched off" in capsys.readouterr().out
    assert (tmp_path / "volume.png").exists() and not list(tmp_path.glob("*.gif"))


@pytest.mark.parametrize("args, fragment", [
    (["deform", "a.obj"], "required: OUT"),
    (["deform", "a.obj", "b.obj", "--lattice", "3x3"], "--lattice"),
    (["deform", "a.obj", "b.obj", "--twist", "lots"], "--twist"),
    (["deform", "a.obj", "b.obj", "--preserve", "w"], "--preserve"),
    (["deform", "a.obj", "b.obj", "--drag", "1,2:3,4,5"], "--drag"),
    (["deform", "a.obj", "b.obj", "--drag", "1,2,3"], "--drag"),
    (["deform", "a.obj", "b.obj", "--squash", "nan"], "--squash"),
    (["deform", "a.obj", "b.obj", "--backend", "cuda"], "--backend"),
    (["demo", "--size", "huge"], "--size"),
    (["bench", "--repeats", "0"], "--repeats"),
    (["frobnicate"], "invalid choice"),
    ([], "required"),
])
def test_bad_arguments_exit_2_with_one_line(args, fragment, capsys):
    with pytest.raises(SystemExit) as e:
        main(args)
    assert e.value.code == 2
    line = _one_line_error(capsys.readouterr().err, "vpffd")
    assert fragment in line


def test_bad_values_after_parsing_exit_2(tmp_path, capsys):
    src = _write_obj(tmp_path / "ball.obj", shapes.icosphere(1))
    for extra in (["--squash", "0"], ["--lattice", "3x3x3"], ["--render", "x.jpg"], ["--padding", "-0.5"],
                  ["--up", "z", "--bend", "30", "--toward", "z"], ["--axis", "x", "--bend", "30", "--toward", "x"]):
        assert main(["deform", str(src), str(tmp_path / "o.obj"), *extra]) == 2, extra
        _one_line_error(capsys.readouterr().err, "vpffd deform")
    assert not (tmp_path / "o.obj").exists()
    for extra in (["--degree", "9"], ["--lattice", "3"]):  # as for deform, not exit 1 from deep inside
        assert main(["bench", "--no-shared", "--repeats", "1", *extra]) == 2, extra
        assert "--" in _one_line_error(capsys.readouterr().err, "vpffd bench")


@needs_io
def test_bend_about_x_needs_no_toward(tmp_path, capsys):
    src = _write_obj(tmp_path / "ball.obj", shapes.icosphere(1))
    assert main(["deform", str(src), str(tmp_path / "o.obj"), "--axis", "x", "--bend", "30"]) == 0
    assert "towards y" in capsys.readouterr().out


def test_render_folder_checked_before_any_work(tmp_path, capsys):
    src = _write_obj(tmp_path / "ball.obj", shapes.icosphere(1))
    assert main(["deform", str(src), str(tmp_path / "o.obj"), "--render", str(tmp_path / "no" / "o.png")]) == 1
    assert "does not exist" in _one_line_error(capsys.readouterr().err, "vpffd deform")
    assert not (tmp_path / "o.obj").exists()


def test_missing_and_bad_files_exit_1(tmp_path):
    (tmp_path / "garbage.obj").write_bytes(b"\x00\x01 this is not a mesh \xff\n")
    (tmp_path / "folder.obj").mkdir()
    (tmp_path / "empty.ply").write_text("")
    cases = [("deform", "missing.obj", "out.obj"), ("deform", "garbage.obj", "out.obj"),
             ("deform", "folder.obj", "out.obj"), ("info", "missing.off"), ("info", "garbage.obj"),
             ("info", "empty.ply")]
    for args in cases:
        status, stdout, stderr = _run(*args, cwd=tmp_path)
        assert status == 1, (args, stderr)
        line = _one_line_error(stderr, f"vpffd {args[0]}")
        assert "error" in line
    status, _, stderr = _run("deform", "garbage.obj", tmp_path / "no" / "such" / "out.obj", cwd=tmp_path)
    assert status == 1 and "does not exist" in _one_line_error(stderr, "vpffd deform")


@needs_io
def test_deform_end_to_end(tmp_path):
    ball = shapes.icosphere(3)
    src = _write_obj(tmp_path / "ball.obj", ball)
    status, stdout, stderr = _run("deform", src, "out.obj", "--lattice", "6x6x6", "--squash", "0.5",
                                  "--twist", "90", "--preserve", "xy", "--up", "z", cwd=tmp_path)
    assert status == 0, stderr
    assert "plain FFD" in stdout and "-" in stdout
    out = vpffd.load_mesh(tmp_path / "out.obj")
    assert out.n_vertices == ball.n_vertices
    assert abs(out.volume - ball.volume) < 1e-6 * ball.volume  # OBJ text keeps ~1e-9
    assert np.ptp(out.vertices[:, 2]) < 0.75 * np.ptp(ball.vertices[:, 2])  # the squash happened

    status, stdout, stderr = _run("deform", src, "plain.obj", "--squash", "0.5", "--preserve", "none", cwd=tmp_path)
    assert status == 0, stderr
    plain = vpffd.load_mesh(tmp_path / "plain.obj")
    assert plain.volume == pytest.approx(0.5 * ball.volume, rel=1e-6)


@needs_io
def test_deform_drag(tmp_path, capsys):
    ball = shapes.icosphere(2)
    src = _write_obj(tmp_path / "ball.obj", ball)
    top = ball.vertices[np.argmax(ball.vertices[:, 2])]
    drag = f"{top[0]},{top[1]},{top[2]}:0.3,0,1.4"
    assert main(["deform", str(src), str(tmp_path / "d.obj"), "--drag", drag, "--lattice", "6"]) == 0
    assert "dragged points reached" in capsys.readouterr().out
    out = vpffd.load_mesh(tmp_path / "d.obj")
    assert np.min(np.linalg.norm(out.vertices - [0.3, 0, 1.4], axis=1)) < 1e-6
    assert out.volume == pytest.approx(ball.volume, rel=1e-6)


@needs_io
def test_info(tmp_path, capsys):
    src = _write_obj(tmp_path / "ball.obj", shapes.icosphere(2))
    assert main(["info", str(src)]) == 0
    assert "ball.obj" in capsys.readouterr().out
    m = shapes.icosphere(1)
    open_mesh = _write_obj(tmp_path / "open.obj", vpffd.Mesh(m.vertices, m.faces[1:]))
    status = main(["info", str(open_mesh)])
    out = capsys.readouterr().out
    assert status == 1 and "open.obj" in out


@pytest.mark.skipif(not (HAS_IO and HAS_RENDER), reason="needs OpenMesh and Embree")
def test_deform_render(tmp_path):
    src = _write_obj(tmp_path / "ball.obj", shapes.icosphere(2))
    status, _, stderr = _run("deform", src, "o.obj", "--bend", "60", "--render", "o.png", "--size", "160x120",
                             cwd=tmp_path)
    assert status == 0, stderr
    from PIL import Image
    assert Image.open(tmp_path / "o.png").size == (160, 120)


def test_bench_runs(tmp_path, capsys):
    pytest.importorskip("vpffd.cli.benchmark")
    assert main(["bench", "--no-shared", "--repeats", "1", "--no-csr", "--json", str(tmp_path / "b.json")]) == 0
    out = capsys.readouterr().out
    assert "| mesh |" in out and (tmp_path / "b.json").exists()


def test_progress_bar_only_after_a_second():
    import io
    import time

    from vpffd.cli.progress import Progress

    class Tty(io.StringIO):
        def isatty(self):
            return True

    s = Tty()
    p = Progress("work", 10, delay=1.0, stream=s)
    p(5, 10)
    assert s.getvalue() == ""
    p.start -= 2.0  # as if two seconds had passed
    p(10, 10)
    assert "work [" in s.getvalue() and "10/10" in s.getvalue()
    p.close()
    assert s.getvalue().endswith("\r")
    quiet = io.StringIO()  # not a terminal: nothing, however long it takes
    q = Progress("work", 3, delay=0.0, stream=quiet)
    time.sleep(0.01)
    q(3, 3)
    q.close()
    assert quiet.getvalue() == ""


def test_deform_size_needs_render(tmp_path, capsys):
    """--size without --render was silently ignored."""
    src = _write_obj(tmp_path / "ball.obj", shapes.icosphere(1))
    assert main(["deform", str(src), str(tmp_path / "o.obj"), "--size", "160x120"]) == 2
    assert "--size" in _one_line_error(capsys.readouterr().err, "vpffd deform")
    assert not (tmp_path / "o.obj").exists()


def test_demo_size_checked_before_deforming(tmp_path, monkeypatch):
    """A bad size failed only after all the deforming, at the first frame drawn."""
    from vpffd.cli import demo

    def no_deforming(*a, **k):
        raise AssertionError("deformed before checking the size")

    monkeypatch.setattr(demo, "run_animation", no_deforming)
    for size in ((0, 10), "big", (10.5, 10)):
        with pytest.raises(vpffd.InvalidInputError, match="size"):
            demo.run_demo(out=tmp_path / "d", quick=True, size=size)
    assert not (tmp_path / "d").exists()


@pytest.mark.skipif(not HAS_RENDER,
                    reason="needs vpffd.render with Embree and Pillow")
def test_demo_rerun_removes_stale_frames(tmp_path):
    """Frames of an earlier, longer run stayed next to the new ones."""
    import io

    from vpffd.cli.demo import run_demo
    fdir = tmp_path / "twisting_cube"  # 9 frames with quick: frame_000..frame_008
    fdir.mkdir()
    for name in ("frame_008.png", "frame_009.png", "frame_024.png", "frame_1000.png",
                 "frame_9.png", "frame_0024.png", "frame_010.png.bak", "notes.png"):
        (fdir / name).write_bytes(b"old")
    r = run_demo(out=tmp_path, quick=True, size=(16, 12), stream=io.StringIO(), motion=False)
    assert r["rendered"]
    names = sorted(p.name for p in fdir.iterdir())
    assert [n for n in names if n.startswith("frame_") and n.endswith(".png") and len(n) == 13] == \
        [f"frame_{i:03d}.png" for i in range(9)]
    assert (fdir / "frame_008.png").read_bytes() != b"old"
    for kept in ("frame_9.png", "frame_0024.png", "frame_010.png.bak", "notes.png"):  # not the demo's names
        assert (fdir / kept).read_bytes() == b"old"
    assert not (fdir / "frame_1000.png").exists()


def test_devices_lists_backends_and_vulkan(capsys, monkeypatch):
    monkeypatch.delenv("VPFFD_VULKAN_PRECISION", raising=False)
    assert main(["devices"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("backends, best first: ") and "serial" in out
    for d in vpffd.vulkan_devices():
        assert d["name"] in out
        if d["suitable"]:
            assert ("sums in float64" if d["float64"] else "sums in float-float") in out
    monkeypatch.setenv("VPFFD_VULKAN_PRECISION", "float-float")
    assert main(["devices"]) == 0
    if any(d["suitable"] for d in vpffd.vulkan_devices()):
        assert "sums in float-float (VPFFD_VULKAN_PRECISION)" in capsys.readouterr().out
    monkeypatch.setenv("VPFFD_VULKAN_PRECISION", "bogus")  # refused as Deformer refuses it
    assert main(["devices"]) == 1
    assert "VPFFD_VULKAN_PRECISION: expected one of" in capsys.readouterr().err


def test_devices_without_a_driver(tmp_path):
    env = dict(os.environ, VK_DRIVER_FILES=str(tmp_path / "none.json"), VK_ICD_FILENAMES=str(tmp_path / "none.json"))
    out = subprocess.run([sys.executable, "-m", "vpffd", "devices"], env=env, capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert "backends, best first:" in out.stdout and "vulkan" not in out.stdout.splitlines()[0]
    if vpffd._core.has_vulkan:
        assert "Vulkan: no device (" in out.stdout


def test_demo_without_pillow_and_matplotlib_says_what_to_install(tmp_path, monkeypatch):
    """A plain `pip install .` has neither; the demo must say so up front, not write nothing silently."""
    import importlib.util
    import io

    from vpffd.cli.demo import run_demo
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a, **k: None if name in ("PIL", "matplotlib") else real(name, *a, **k))
    out = io.StringIO()
    r = run_demo(out=tmp_path, quick=True, stream=out, motion=False)
    text = out.getvalue()
    first = text.index('pip install "vpffd[demo]"')
    assert first < text.index("Twisting cube")  # before the minutes of deforming
    assert "no frames or GIFs written" in text and "no volume plot" in text
    assert not r["rendered"] and not list(tmp_path.glob("*.png")) and not list(tmp_path.glob("*.gif"))
    assert (tmp_path / "volume.csv").exists()


def test_benchmark_finds_the_shared_meshes(shared_meshes):
    # The benchmark's own idea of ../shared (it moved with the CLI once and lost it).
    from vpffd.cli import benchmark
    assert benchmark.SHARED_MESHES.resolve() == shared_meshes.resolve()
    assert "dragon_vrip_welded" in [name for name, _ in benchmark.default_meshes()]
