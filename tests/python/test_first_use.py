"""What a new user meets first: one fold verdict in the command line, the pictures and
Python; one up-axis rule; drags drawn with their targets and a camera option; demo
captions that do not overlap; short reprs; constraints as numpy arrays; logging."""
import logging

import numpy as np
import pytest

import vpffd
from vpffd import folds
from vpffd.cli.main import main

needs_render = pytest.mark.skipif(not vpffd._core.has_embree, reason="no Embree in this build")
needs_io = pytest.mark.skipif(not vpffd._core.has_mesh_io, reason="no mesh file I/O in this build")


# --- one fold verdict ------------------------------------------------------------------
@pytest.fixture(scope="module")
def corner_fold():
    """A unit sphere in a 6^3 trilinear lattice on [-3, 3]^3 whose corner control point
    is pulled past its diagonal neighbour: cell (0, 0, 0) folds, far from the mesh."""
    mesh = vpffd.shapes.icosphere(2)
    lat = vpffd.Lattice([-3, -3, -3], [3, 3, 3], shape=7, degree=1)
    P = np.array(lat.rest_points)
    P[0, 0, 0] = (-1.5, -1.5, -1.5)
    return vpffd.Deformer(mesh, lat), P


def test_folds_only_outside_the_mesh_are_told_apart(corner_fold):
    d, P = corner_fold
    rep = d.check_folds(P)
    assert rep.folded and not rep.mesh_folded
    assert rep.status[0, 0, 0] == folds.FOLDED and not rep.occupied[0, 0, 0]
    assert rep.verdict(short=True).startswith("folds only outside the mesh")
    assert rep.verdict().startswith(rep.verdict(short=True))
    assert rep.verdict(short=True) in repr(rep)
    # The lattice alone has no mesh: its verdict does not speak of one.
    alone = vpffd.check_folds(d.lattice, P)
    assert alone.mesh_folded is None and alone.occupied is None and "mesh" not in alone.verdict()


def test_occupied_cells_are_the_surface_and_its_inside(corner_fold):
    d, _ = corner_fold
    rep = d.check_folds()
    occ = rep.occupied
    # The vertices' cells, and every cell of [-1, 1]^3 (cells 2..3): the sphere of
    # radius 1 (an icosphere's faces cut inside it by at most 1 - cos of half an edge)
    # passes through or covers each of them.
    c = rep.cell_of(d.mesh.vertices)
    assert occ[c[:, 0], c[:, 1], c[:, 2]].all()
    assert occ[2:4, 2:4, 2:4].all()
    # Cells at least 1 away from the sphere hold none of it.
    far = np.ones_like(occ)
    far[1:5, 1:5, 1:5] = False
    assert not occ[far].any()
    # A cell wholly inside, no triangle in it: a sphere of radius 2.9 around cells 2..3.
    big = vpffd.Deformer(vpffd.Mesh(2.9 * d.mesh.vertices, d.mesh.faces), d.lattice).check_folds()
    assert big.occupied[2:4, 2:4, 2:4].all() and not big.occupied[0, 0, 0]
    # An open mesh has no inside: the top cap of the big sphere leaves the centre empty.
    V = 2.9 * d.mesh.vertices
    keep = np.all(V[d.mesh.faces][:, :, 2] > 1.5, axis=1)
    cap = vpffd.Deformer(vpffd.Mesh(V, d.mesh.faces[keep]), d.lattice, outside="extrapolate").check_folds()
    assert not cap.occupied[2:4, 2:4, 2:4].any() and cap.occupied[:, :, 5].any()


def test_the_triangle_box_test_keeps_touching_and_drops_separated():
    T = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]] * 4)
    c = np.array([[0.5, 0.5, 0.0], [2.0, 2.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 0.5]])
    h = np.array([[0.1, 0.1, 0.1], [0.5, 0.5, 0.5], [0.5, 0.5, 0.5], [0.5, 0.5, 0.5]])
    # inside; beyond the hypotenuse; a corner on the hypotenuse; touching the plane from above
    assert folds._triangles_touch_boxes(T, c, h).tolist() == [True, False, True, True]
    c2 = np.array([[0.0, 0.0, 0.51]])
    assert not folds._triangles_touch_boxes(T[:1], c2, h[3:])[0]


@needs_io
def test_cli_names_the_mesh_folds_and_what_to_try(tmp_path, capsys):
    vpffd.save_mesh(tmp_path / "s.obj", vpffd.shapes.icosphere(2))
    assert main(["deform", str(tmp_path / "s.obj"), str(tmp_path / "o.obj"), "--squash", "0.3",
                 "--twist", "200", "--up", "z"]) == 0
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if ln.strip().startswith("folds:"))
    assert "FOLDS in the mesh's cells" in line
    assert "the volume correction folds cells the mesh occupies" in out and "--lattice" in out
    assert "--preserve" in out and "--weights auto" in out


def test_deform_result_repr_carries_the_verdict(corner_fold):
    d, P = corner_fold
    with pytest.warns(vpffd.FoldWarning, match="none of them holds part of the mesh"):
        r = d.deform(P, preserve_volume=False, on_fold="warn")
    assert r.folds.verdict(short=True) in repr(r)


@needs_render
def test_pictures_caption_the_verdict(corner_fold):
    d, P = corner_fold
    r = d.deform(P, preserve_volume=False)
    img = vpffd.render_comparison(d, r, size=(480, 220), lattice_style="none")
    # Red caption text only for folds in the mesh's cells: none here.
    red = (img[..., 0] > 150) & (img[..., 1] < 80) & (img[..., 2] < 80)
    assert not red[:40].any()
    m = vpffd.shapes.icosphere(2)
    lat = vpffd.Lattice.around(m, shape=(8, 8, 8))
    d2 = vpffd.Deformer(m, lat)
    r2 = d2.deform(vpffd.twist(vpffd.squash(lat.control_points, 0.3), 200))
    assert d2.check_folds(r2.control_points).mesh_folded
    img2 = vpffd.render_comparison(d2, r2, size=(480, 220), lattice_style="none")
    fs = max(10, int(round(0.03 * min(220, 1.2 * 480 / 3))))
    red2 = (img2[..., 0] > 150) & (img2[..., 1] < 80) & (img2[..., 2] < 80)
    assert red2[:int(3.9 * fs), 320:].sum() > 10 and not red2[:int(3.9 * fs), :160].any()


# --- one up-axis rule ------------------------------------------------------------------
@needs_io
def test_cli_and_python_take_the_same_up_axis(tmp_path, capsys):
    path = tmp_path / "ball.ply"
    vpffd.save_mesh(path, vpffd.shapes.icosphere(2))  # no flat base: the format decides
    mesh = vpffd.load_mesh(path)
    up, why = vpffd.guess_up_axis(mesh)
    assert up == "y" and ".ply" in why
    assert vpffd.guess_up_axis(mesh.oriented())[0] == "y"
    assert vpffd.guess_up_axis(vpffd.Mesh(mesh.vertices, mesh.faces))[0] == "z"  # no file: vpffd's z
    d = vpffd.Deformer(mesh, vpffd.Lattice.around(mesh, shape=5))
    assert vpffd.guess_up_axis(d.mesh) == (up, why)
    assert main(["deform", str(path), str(tmp_path / "o.ply"), "--squash", "0.8"]) == 0
    out = capsys.readouterr().out
    assert f"up axis {up} (guessed: {why};" in out and f"squash 0.8 along {up}" in out


# --- drags and the camera ----------------------------------------------------------------
@pytest.fixture(scope="module")
def dragged():
    mesh = vpffd.shapes.icosphere(3)
    lat = vpffd.Lattice.around(mesh, shape=(6, 6, 6))
    d = vpffd.Deformer(mesh, lat)
    top = int(np.argmax(mesh.vertices[:, 2]))
    r = d.deform(constraints=(np.array([top]), mesh.vertices[[top]] + [[0.3, 0.0, 0.4]]))
    return d, r, top


@needs_render
def test_drag_picture_shows_the_plain_drag_handles_and_targets(dragged):
    d, r, top = dragged
    size = (600, 260)
    img = vpffd.render_comparison(d, r, size=size, lattice_style="none", color="none", folds=False)
    fs = max(10, int(round(0.03 * min(260, 1.2 * 600 / 3))))
    cap, bar = int(2.7 * fs), 0
    pw = 200
    rest, plain, kept = (img[cap:, i * pw:(i + 1) * pw].astype(int) for i in range(3))
    # The plain FFD panel is the drag without the correction, not the rest shape.
    assert np.abs(plain - rest).max(axis=2).astype(bool).sum() > 200
    red = [((p[..., 0] > 170) & (p[..., 1] < 90) & (p[..., 2] < 90)).sum() for p in (rest, plain, kept)]
    assert min(red) > 10  # every panel shows the target
    # Without the drag's points the red marks are gone.
    import dataclasses
    plain_r = dataclasses.replace(r, constraints=None)
    img0 = vpffd.render_comparison(d, plain_r, size=size, lattice_style="none", color="none", folds=False)
    assert not ((img0[..., 0] > 170) & (img0[..., 1] < 90) & (img0[..., 2] < 90)).any()


@needs_render
def test_all_panels_share_one_framing_with_the_lattice_inside(dragged):
    d, r, _ = dragged
    P = vpffd.squash(d.lattice.control_points, 0.5)
    r2 = d.deform(P, axes="xy")
    img = vpffd.render_comparison(d, r2, size=(600, 260), color="none", folds=False, lattice_style="full")
    fs = max(10, int(round(0.03 * min(260, 1.2 * 600 / 3))))
    cap = int(2.7 * fs)
    for i in range(3):
        panel = img[cap:, i * 200:(i + 1) * 200]
        # nothing runs off a panel's sides: the outer columns stay background
        assert (panel[:, :1] == 255).all() and (panel[:, -1:] == 255).all(), i


def test_views_parse_and_point_the_camera():
    from vpffd.views import parse_view, view_direction
    assert parse_view("front") == (0.0, 0.0) and parse_view("30, 20") == (30.0, 20.0)
    assert np.allclose(view_direction("z", "front"), [0, -1, 0])
    assert np.allclose(view_direction("z", "right"), [1, 0, 0])
    assert np.allclose(view_direction("y", "back"), [0, 0, -1])
    assert np.allclose(view_direction("z", "top"), [0, 0, 1])
    for bad in ("sideways", "1,2,3", "0,91", (0, float("nan"))):
        with pytest.raises(vpffd.InvalidInputError, match="view"):
            parse_view(bad)
    # Straight down is framed too (no NaN): the model's back is up in the image.
    cam = vpffd.comparison.fit_camera(vpffd.shapes.icosphere(1).vertices, up="z", view="top")
    assert np.isfinite(cam.eye).all() and np.allclose(cam.up, [0, 1, 0])


@needs_render
@needs_io
def test_cli_view_turns_the_camera(tmp_path, capsys):
    from PIL import Image
    vpffd.save_mesh(tmp_path / "b.obj", vpffd.shapes.bumpy_sphere(2))
    imgs = {}
    for view in ("front", "top", "0,20"):
        png = tmp_path / f"{view.replace(',', '_')}.png"
        assert main(["deform", str(tmp_path / "b.obj"), str(tmp_path / "o.obj"), "--squash", "0.7", "--up", "z",
                     "--render", str(png), "--size", "300x140", "--view", view]) == 0
        imgs[view] = np.asarray(Image.open(png)).astype(int)
    # squashed along z: a wide ellipse from the front, a disc from the top
    assert np.abs(imgs["front"] - imgs["top"]).max(axis=2).astype(bool).mean() > 0.05
    with pytest.raises(SystemExit) as exit_:
        main(["deform", str(tmp_path / "b.obj"), str(tmp_path / "o.obj"), "--view", "sideways"])
    assert exit_.value.code == 2
    assert "--view" in capsys.readouterr().err


# --- demo captions -----------------------------------------------------------------------
def test_key_frame_captions_do_not_overlap():
    from PIL import Image
    from vpffd.cli.demo import CAPTION_LINES
    from vpffd.cli.frames import label_boxes
    img = Image.new("RGB", (320, 240), "white")
    boxes = label_boxes(img, ["preserved, xy only", "volume kept (error +1e-16)", "fold check undecided"])
    boxes += label_boxes(img, ["frame 16"], first=CAPTION_LINES)
    row = Image.new("RGB", (640, 240), "white")
    row_boxes = label_boxes(row, ["plain FFD", "volume -12.0 %", "lattice FOLDS here"])
    row_boxes += label_boxes(row, ["frame 24  t = 1.20 s"], first=CAPTION_LINES)
    for bs in (boxes, row_boxes):
        for i in range(len(bs)):
            for j in range(i + 1, len(bs)):
                a, b = bs[i], bs[j]
                assert a[3] <= b[1] or b[3] <= a[1] or a[2] <= b[0] or b[2] <= a[0], (a, b)


# --- short reprs -------------------------------------------------------------------------
def _short(obj, lines=4, chars=600):
    text = repr(obj)
    assert len(text.splitlines()) <= lines and len(text) <= chars, text
    assert "array(" not in text
    return text


def test_results_print_short(dragged):
    d, r, _ = dragged
    assert "642" in _short(r) and "constraints met" in _short(r)
    _short(d.check_folds(r.control_points))
    mr = vpffd.Multires(vpffd.shapes.bumpy_sphere(2), smoothing=5, fit_rounds=1)
    lat = vpffd.Lattice.around(mr.mesh, shape=5)
    assert "volume" in _short(vpffd.MultiresDeformer(mr, lat).deform(vpffd.squash(lat.control_points, 0.7)))
    from vpffd.animate import Twist
    res = vpffd.run_animation(d.mesh, d.lattice, Twist(d.lattice, angle=30), frames=3)
    _short(res)


# --- constraints as arrays ----------------------------------------------------------------
def test_constraints_as_arrays_match_the_pairs(dragged):
    d, _, _ = dragged
    idx = np.array([3, 40], dtype=np.int32)
    X = d.mesh.vertices
    T = X[idx] + [[0.1, 0, 0], [0, 0.1, 0.05]]
    idx0, T0 = idx.copy(), T.copy()
    a = d.deform(constraints=(idx, T))
    b = d.deform(constraints=[(int(i), t) for i, t in zip(idx, T)])
    assert np.array_equal(a.vertices, b.vertices)
    assert np.array_equal(idx, idx0) and np.array_equal(T, T0)
    assert np.array_equal(a.constraints[0], X[idx]) and np.array_equal(a.constraints[1], T)
    assert not a.constraints[0].flags.writeable
    # rest-space points (k, 3) as sources, and a result's constraints given back
    c = d.deform(constraints=(X[idx], T))
    assert np.allclose(c.vertices, a.vertices, atol=1e-12)
    assert np.array_equal(d.deform(constraints=a.constraints).vertices, c.vertices)


@pytest.mark.parametrize("cons, error, match", [
    ((np.array([1, 2]), np.zeros((3, 3))), vpffd.InvalidInputError, r"indices: expected shape \(3,\)"),
    ((np.array([1, 2]), np.zeros((2, 2))), vpffd.InvalidInputError, r"targets: expected shape \(k, 3\)"),
    ((np.array([1, 99999]), np.zeros((2, 3))), vpffd.InvalidInputError, r"indices\[1\] = 99999 out of range"),
    ((np.array([-1]), np.zeros((1, 3))), vpffd.InvalidInputError, r"indices\[0\] = -1 out of range"),
    ((np.array([True]), np.zeros((1, 3))), TypeError, "indices: expected integers"),
    ((np.array(["a"]), np.zeros((1, 3))), TypeError, "sources: expected vertex indices"),
    ((np.array([1]), np.array([["a", "b", "c"]])), TypeError, "targets: expected real numbers"),
    ((np.array([1]), np.array([[0, np.nan, 0]])), vpffd.InvalidInputError, r"targets: row 0 contains NaN"),
    ((np.zeros((2, 2)), np.zeros((2, 3))), vpffd.InvalidInputError, r"sources: expected vertex indices \(2,\)"),
    ("abc", TypeError, "expected a list of"),
    ([(1,)], vpffd.InvalidInputError, r"constraints\[0\]: expected a \(source, target\) pair"),
])
def test_bad_constraint_arrays_are_named(dragged, cons, error, match):
    d, _, _ = dragged
    with pytest.raises(error, match=match):
        d.deform(constraints=cons)


# --- logging -------------------------------------------------------------------------------
def test_the_library_configures_no_handlers():
    assert logging.getLogger("vpffd").handlers == []


@needs_io
def test_file_reads_and_writes_and_decompositions_are_logged(tmp_path, caplog):
    with caplog.at_level(logging.INFO, logger="vpffd"):
        vpffd.save_mesh(tmp_path / "m.obj", vpffd.shapes.bumpy_sphere(2))
        vpffd.load_mesh(tmp_path / "m.obj")
        vpffd.Multires(vpffd.load_mesh(tmp_path / "m.obj"), smoothing=5, fit_rounds=1)
    text = caplog.text
    assert "wrote " in text and "read " in text and "vertices" in text
    assert "Multires: decomposing" in text and "Multires: decomposed in" in text


@needs_io
def test_cli_verbose_logs_stages_to_stderr(tmp_path, capsys):
    vpffd.save_mesh(tmp_path / "s.obj", vpffd.shapes.icosphere(2))
    assert main(["deform", str(tmp_path / "s.obj"), str(tmp_path / "o.obj"), "--squash", "0.8", "-v"]) == 0
    err = capsys.readouterr().err
    assert "vpffd deform: [" in err and "read " in err and "deform: deforming" in err and "wrote " in err
    assert logging.getLogger("vpffd").handlers == []  # taken off again
    assert main(["deform", str(tmp_path / "s.obj"), str(tmp_path / "o.obj"), "--squash", "0.8"]) == 0
    assert capsys.readouterr().err == ""
