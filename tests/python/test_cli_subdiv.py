"""``vpffd subdiv`` (a mesh edited as a displaced subdivision surface, paper 002 §5),
the point drags behind its ``--drag``, its picture, and the demo's subdivision scene
with its captions checked against numbers computed here."""
import importlib.util
import re

import numpy as np
import pytest

import vpffd
from vpffd import shapes
from vpffd.cli.main import main

HAS_IO = vpffd._core.has_openmesh
HAS_RENDER = vpffd._core.has_embree and importlib.util.find_spec("PIL") is not None
needs_osd = pytest.mark.skipif(not vpffd.subdivision.available(),
                               reason="this build has no vpffd::subdiv (install libosd-dev and rebuild)")
needs_io = pytest.mark.skipif(not HAS_IO, reason="this build has no OpenMesh (mesh files)")
needs_render = pytest.mark.skipif(not HAS_RENDER, reason="needs Embree (vpffd.render) and Pillow")


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
    assert lines[0].startswith(prog) and ": error: " in lines[0], err
    assert "Traceback" not in err
    return lines[0]


def _status(argv):
    """main(argv)'s exit status, whether argparse exits or main returns."""
    try:
        return main(argv)
    except SystemExit as e:
        return e.code


def _area_normals(V, F):
    """Area-weighted vertex normals, computed here: the sum of the adjacent faces'
    cross products (twice their area times their unit normal), normalised."""
    c = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    N = np.zeros_like(V)
    for k in range(3):
        np.add.at(N, F[:, k], c)
    return N / np.linalg.norm(N, axis=1, keepdims=True)


def _volume(V, F):
    return float(np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])).sum() / 6.0)


BALL = shapes.bumpy_sphere(3)  # 642 vertices
_sm = {}


def _decomposition(n=80):
    if n not in _sm:
        _sm[n] = vpffd.SubdivisionMultires(BALL, control_vertices=n)
    return _sm[n]


# --- the library part: drags -------------------------------------------------------
@needs_osd
def test_drag_moves_the_foot_points_exactly_and_only_their_stencils():
    sm = _decomposition()
    top, side = np.argmax(BALL.vertices[:, 2]), np.argmax(BALL.vertices[:, 0])
    P = BALL.vertices[[top, side]]
    T = P + [[0.0, 0.0, 0.3], [0.2, 0.0, 0.0]]
    e = vpffd.subdivision_edits.drag(sm, P, T)
    assert list(e.vertices) == [top, side] and e.snap_distances.max() == 0.0
    r = sm.deform(e.control_points)
    # The foot points move by the offsets exactly (the least-norm solve of Phi delta = D).
    np.testing.assert_allclose(r.base_vertices[[top, side]] - sm.limit_points[[top, side]], T - P, atol=1e-12)
    # Only the control points in the two stencils moved; a vertex whose stencil misses
    # them keeps its identity-frame position to the bit.
    changed = np.flatnonzero(np.any(e.control_points != sm.control_points, axis=1))
    assert set(changed) <= set(e.moved) and len(e.moved) < sm.n_control // 2
    st = sm.stencils()
    rows = np.repeat(np.arange(sm.n_vertices), np.diff(st["indptr"]))
    reached = np.unique(rows[np.isin(st["indices"], e.moved)])
    still = np.setdiff1d(np.arange(sm.n_vertices), reached)
    assert len(still) > sm.n_vertices // 10  # 80 control points on 642 vertices: wide stencils
    ident = sm.deform(sm.control_points)
    np.testing.assert_array_equal(r.vertices[still], ident.vertices[still])


@needs_osd
def test_drag_refuses_two_points_on_one_vertex_and_bad_shapes():
    sm = _decomposition()
    p = BALL.vertices[0]
    with pytest.raises(vpffd.InvalidInputError, match="both snap to vertex 0"):
        vpffd.subdivision_edits.drag(sm, [p, p + 1e-9], [p, p])
    with pytest.raises(vpffd.InvalidInputError, match="as many targets as points"):
        vpffd.subdivision_edits.drag(sm, [p, p], [p])
    with pytest.raises(vpffd.InvalidInputError, match="control_points must have shape"):
        vpffd.subdivision_edits.drag(sm, [p], [p], control_points=np.zeros((3, 3)))


# --- the command ---------------------------------------------------------------------
@needs_osd
@needs_io
def test_subdiv_writes_out_with_the_input_faces(tmp_path, capsys):
    src = _write_obj(tmp_path / "ball.obj", BALL)
    assert main(["subdiv", str(src), str(tmp_path / "out.obj"), "--control-vertices", "80"]) == 0
    text = capsys.readouterr().out
    out = vpffd.load_mesh(tmp_path / "out.obj")
    np.testing.assert_array_equal(out.faces, BALL.faces)
    # No drag: the identity frame, p = S(t) + d N_S(t) at exact foot points.
    # (the mesh writer stores single-precision text: ~6e-8 on coordinates of size 1)
    assert np.abs(out.vertices - BALL.vertices).max() < 1e-6
    m = re.search(r"control mesh of (\d+) points", text)
    assert m and int(m.group(1)) == _decomposition().n_control
    assert "unresolved foot points: 0" in text
    m = re.search(r"fit RMS \|p - S\|: (\S+) before, (\S+) after", text)
    assert m and float(m.group(2)) < float(m.group(1))
    assert re.search(r"frame \d+\.\d ms", text) and "wrote" in text


@needs_osd
@needs_io
def test_subdiv_drag_moves_the_region_and_leaves_far_vertices(tmp_path, capsys):
    src = _write_obj(tmp_path / "ball.obj", BALL)
    i = int(np.argmax(BALL.vertices[:, 2]))
    p = BALL.vertices[i]
    target = p + [0.0, 0.0, 0.3]
    drag = ",".join(map(repr, map(float, p))) + ":" + ",".join(map(repr, map(float, target)))
    assert main(["subdiv", str(src), str(tmp_path / "d.obj"), "--control-vertices", "80", f"--drag={drag}",
                 "--preserve-volume"]) == 0
    text = capsys.readouterr().out
    out = vpffd.load_mesh(tmp_path / "d.obj").vertices
    # The dragged vertex went most of the way (the foot point exactly; the normal turns).
    assert np.linalg.norm(out[i] - target) < 0.1 * 0.3
    assert out[i, 2] > p[2] + 0.25
    # Its neighbourhood followed, the far side barely moved (the volume correction
    # shifts every control point a little to keep the base's volume).
    move = np.linalg.norm(out - BALL.vertices, axis=1)
    near = np.linalg.norm(BALL.vertices - p, axis=1) < 0.15
    far = BALL.vertices[:, 2] < 0.0
    assert move[near].min() > 0.05
    assert move[far].max() < 0.02
    m = re.search(r"base volume kept \(relative error (\S+)\)", text)
    assert m and abs(float(m.group(1))) < 1e-12
    assert "moved" in text and "control points" in text


def test_help_lists_the_options(capsys):
    with pytest.raises(SystemExit) as e:
        main(["subdiv", "--help"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    for opt in ("--control-vertices", "--drag", "--render", "--preserve-volume", "--scheme"):
        assert opt in out


@needs_osd
@needs_io
def test_open_mesh_needs_max_unresolved_and_reports_the_count(tmp_path, capsys):
    # The sphere without its top cap: vertices near the rim have no exact foot point.
    keep = BALL.vertices[BALL.faces].mean(axis=1)[:, 2] < 0.6
    used = np.unique(BALL.faces[keep])
    remap = np.full(BALL.n_vertices, -1)
    remap[used] = np.arange(len(used))
    src = _write_obj(tmp_path / "open.obj", vpffd.Mesh(BALL.vertices[used], remap[BALL.faces[keep]].astype(np.int32)))
    out = tmp_path / "o.obj"
    assert _status(["subdiv", str(src), str(out), "--control-vertices", "80"]) == 1
    line = _one_line_error(capsys.readouterr().err, "vpffd subdiv")
    m = re.search(r"(\d+) of \d+ fine vertices have no exact foot point", line)
    assert m and "--max-unresolved" in line and not out.exists()
    n = int(m.group(1))
    assert main(["subdiv", str(src), str(out), "--control-vertices", "80", "--max-unresolved", str(n)]) == 0
    text = capsys.readouterr().out
    assert f"unresolved foot points: {n} (first:" in text and "not closed" in text
    assert _status(["subdiv", str(src), str(out), "--control-vertices", "80", "--max-unresolved", str(n - 1)]) == 1


@pytest.mark.parametrize("extra, fragment", [
    (["--control-vertices", "0"], "--control-vertices"),
    (["--control-vertices", "3"], "--control-vertices"),
    (["--drag", "1,2:3,4,5"], "--drag"),
    (["--scheme", "butterfly"], "--scheme"),
    (["--render", "pic.jpg"], "--render"),
    (["--size", "200x100"], "--size"),
    (["--fairness", "-1"], "--fairness"),
    (["--iterations", "-1"], "--iterations"),
    (["--max-unresolved", "x"], "--max-unresolved"),
])
def test_bad_arguments_exit_2_and_leave_out_untouched(tmp_path, capsys, extra, fragment):
    src = _write_obj(tmp_path / "ball.obj", shapes.icosphere(1))
    out = tmp_path / "out.obj"
    out.write_bytes(b"old")
    assert _status(["subdiv", str(src), str(out), *extra]) == 2
    assert fragment in _one_line_error(capsys.readouterr().err, "vpffd")
    assert out.read_bytes() == b"old"


@needs_io
def test_unknown_out_format_and_out_is_in_exit_2(tmp_path, capsys):
    src = _write_obj(tmp_path / "ball.obj", shapes.icosphere(1))
    assert _status(["subdiv", str(src), str(tmp_path / "out.xyz")]) == 2
    assert "unknown mesh format" in _one_line_error(capsys.readouterr().err, "vpffd subdiv")
    before = src.read_bytes()
    assert _status(["subdiv", str(src), str(src)]) == 2
    assert "OUT is IN" in _one_line_error(capsys.readouterr().err, "vpffd subdiv")
    assert src.read_bytes() == before


@needs_osd
@needs_io
def test_drags_on_one_vertex_exit_1_and_leave_out_untouched(tmp_path, capsys):
    src = _write_obj(tmp_path / "ball.obj", BALL)
    out = tmp_path / "out.obj"
    out.write_bytes(b"old")
    p = BALL.vertices[0]
    d = f"{p[0]},{p[1]},{p[2]}:0,0,0"
    assert _status(["subdiv", str(src), str(out), "--control-vertices", "80", f"--drag={d}", f"--drag={d}"]) == 1
    assert "both snap to vertex" in _one_line_error(capsys.readouterr().err, "vpffd subdiv")
    assert out.read_bytes() == b"old"


@needs_osd
@needs_io
@needs_render
def test_subdiv_render_writes_a_png(tmp_path, capsys):
    src = _write_obj(tmp_path / "ball.obj", BALL)
    p = BALL.vertices[0]
    status = main(["subdiv", str(src), str(tmp_path / "o.obj"), "--control-vertices", "80",
                   f"--drag={p[0]},{p[1]},{p[2]}:{1.2 * p[0]},{1.2 * p[1]},{1.2 * p[2]}", "--render",
                   str(tmp_path / "o.png"), "--size", "400x150", "--up", "z"])
    assert status == 0
    assert "picture:" in capsys.readouterr().out
    from PIL import Image
    img = np.asarray(Image.open(tmp_path / "o.png"))
    assert img.shape == (150, 400, 3)
    # Four panels, each with something drawn in it (not the white background alone).
    cap = int(2.7 * max(10, round(0.03 * min(150, 1.2 * 400 / 4))))
    for k in range(4):
        panel = img[cap:, k * 100:(k + 1) * 100]
        assert (panel < 200).any(axis=2).mean() > 0.05, k


@needs_render
def test_render_net_refuses_a_lattice_too():
    m = shapes.icosphere(1)
    with pytest.raises(vpffd.InvalidInputError, match="net or a lattice"):
        vpffd.render(m, size=(32, 32), net=(m.vertices, [[0, 1]]), control_points=np.zeros((2, 2, 2, 3)))
    with pytest.raises(vpffd.InvalidInputError, match="edges"):
        vpffd.render(m, size=(32, 32), net=(m.vertices, [[0, len(m.vertices)]]))


# --- the demo scene ------------------------------------------------------------------
@needs_osd
def test_demo_scene_captions_are_the_computed_numbers(tmp_path):
    from vpffd.cli import subdiv_scene as ss
    s = ss.run(ss.pulled_body(quick=True))
    sm, F = s.results["decomposition"], s.mesh.faces
    last = s.frames - 1
    C = s.results["control_points"][last]
    # The edit, independently: the three front control points moved along x by the pull.
    moved = np.flatnonzero(np.any(C != sm.control_points, axis=1))
    assert len(moved) == ss.MOVED
    np.testing.assert_allclose(C[moved, 0] - sm.control_points[moved, 0], s.results["pull"][last])
    r = sm.deform(C)
    angles = vpffd.normals.angles_deg(r.normals, _area_normals(r.vertices, F))
    vol = _volume(r.vertices, F) / _volume(s.mesh.vertices, F) - 1.0
    shift = np.linalg.norm(r.base_vertices - sm.limit_points, axis=1).max()
    caps = ss.captions(s, last)
    assert [c[0] for c in caps] == ["control mesh + limit surface", "edited", "detailed result",
                                    "approximate normal error"]
    m = re.fullmatch(r"(\d+) control points, fit RMS (\S+) -> (\S+)", caps[0][1])
    assert int(m.group(1)) == sm.n_control
    assert float(m.group(2)) == pytest.approx(sm.rms_initial, rel=1e-2)
    assert float(m.group(3)) == pytest.approx(sm.rms_final, rel=1e-2)
    m = re.fullmatch(r"(\d+) control points moved, limit surface up to (\S+)", caps[1][1])
    assert int(m.group(1)) == ss.MOVED and float(m.group(2)) == pytest.approx(shift, rel=1e-2)
    m = re.fullmatch(r"volume (\S+) %", caps[2][1])
    assert float(m.group(1)) == pytest.approx(100 * vol, abs=0.006)
    assert abs(vol) > 1e-3  # the pull changes the volume: the caption is not a constant
    m = re.fullmatch(r"mean (\S+) deg, max (\S+) \(colour 0-(\S+)\)", caps[3][1])
    assert float(m.group(1)) == pytest.approx(np.mean(angles), abs=0.006)
    assert float(m.group(2)) == pytest.approx(np.max(angles), abs=0.006)
    assert np.max(angles) > 0.05  # a real edit, so a real error
    if HAS_RENDER:
        files = ss.render(s, tmp_path, (160, 120))
        from PIL import Image
        assert Image.open(tmp_path / "subdiv.png").size == (4 * 160, 120)
        assert Image.open(tmp_path / "subdiv.gif").n_frames == s.frames
        assert len(files) == s.frames + 2
    ss.write_csv(s, tmp_path / "subdiv.csv")
    rows = (tmp_path / "subdiv.csv").read_text().splitlines()
    assert len(rows) == 1 + s.frames and rows[0].startswith("frame,pull")


@needs_osd
def test_run_demo_includes_the_subdivision_scene(tmp_path):
    import io

    from vpffd.cli.demo import run_demo
    stream = io.StringIO()
    r = run_demo(out=tmp_path, quick=True, render=False, stream=stream, motion=False, multires=False)
    text = stream.getvalue()
    assert "Displaced subdivision surface: bumpy body" in text
    s = r["subdiv_scene"]
    assert s is not None and tmp_path / "subdiv.csv" in r["files"]
    rows = (tmp_path / "subdiv.csv").read_text().splitlines()
    assert len(rows) == 1 + s.frames
    assert run_demo(out=tmp_path / "no", quick=True, render=False, stream=io.StringIO(), motion=False,
                    multires=False, subdiv=False)["subdiv_scene"] is None
