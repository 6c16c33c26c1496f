"""Pictures that explain a deformation (issue 16): panels, colours of det J, folds,
framing, the up axis, the lattice styles and the CLI's --render."""
import numpy as np
import pytest

import vpffd
from vpffd import comparison
from vpffd.colormap import FOLD_COLOR, volume_change_colors

pytestmark = pytest.mark.skipif(not vpffd._core.has_embree, reason="built without Embree")
PIL = pytest.importorskip("PIL")

SIZE = (600, 260)


@pytest.fixture(scope="module")
def squashed():
    """A ball squashed to 60 % along z, preserved along xy: plain FFD loses 40 %."""
    mesh = vpffd.shapes.icosphere(3)
    lat = vpffd.Lattice.around(mesh, shape=(5, 5, 5))
    d = vpffd.Deformer(mesh, lat)
    r = d.deform(vpffd.edits.squash(lat.control_points, 0.6, axis="z"), axes="xy")
    return d, r


def layout(img, n):
    """(caption height, panel height, panel width, x0) as render_comparison lays them out."""
    h, w = img.shape[:2]
    fs = max(10, int(round(0.03 * min(h, 1.2 * w / n))))
    cap, bar = int(3.9 * fs), int(3.0 * fs)  # three caption lines: title, volume, fold verdict
    return cap, h - cap - bar, w // n, (w - n * (w // n)) // 2


def panels(img, n):
    cap, ph, pw, x0 = layout(img, n)
    return [img[cap:cap + ph, x0 + i * pw:x0 + (i + 1) * pw].astype(int) for i in range(n)]


def mesh_mask(panel):
    return (panel != 255).any(axis=2)


def test_three_panels_each_filled(squashed):
    d, r = squashed
    img = vpffd.render_comparison(d, r, size=SIZE, lattice_style="none")
    assert img.shape == (SIZE[1], SIZE[0], 3) and img.dtype == np.uint8
    for i, p in enumerate(panels(img, 3)):
        m = mesh_mask(p)
        # Filling the panel: one camera fits all three meshes with a 4 % margin, so the
        # widest of them spans >= 1 / 1.04 of the limiting side; each of them still
        # covers a good part of its panel (a missing panel covers nothing).
        ys, xs = np.nonzero(m)
        assert m.mean() > 0.2, (i, m.mean())
        assert max((xs.max() - xs.min() + 1) / p.shape[1], (ys.max() - ys.min() + 1) / p.shape[0]) > 0.6, i
    # The widest mesh (the squashed ones spread along x) reaches the limiting side.
    spans = []
    for p in panels(img, 3):
        ys, xs = np.nonzero(mesh_mask(p))
        spans.append(max((xs.max() - xs.min() + 1) / p.shape[1], (ys.max() - ys.min() + 1) / p.shape[0]))
    assert max(spans) > 0.9


def test_colours_follow_det_j(squashed):
    """Plain FFD compresses (det J = 0.6): blue; the corrected one is near 1 on
    average; the rest is neutral. An inverted map would make the plain panel red."""
    d, r = squashed
    img = vpffd.render_comparison(d, r, size=SIZE, lattice_style="none")
    rest, plain, kept = panels(img, 3)
    mr, mp = mesh_mask(rest), mesh_mask(plain)
    blue_minus_red = lambda p, m: float((p[m][:, 2] - p[m][:, 0]).mean())  # noqa: E731
    assert blue_minus_red(plain, mp) > 40
    assert abs(blue_minus_red(rest, mr)) < 15
    detj = comparison.local_volume_change(d, r.control_points - r.offsets)
    np.testing.assert_allclose(detj, 0.6, rtol=1e-12)  # a linear scaling: exact
    # expanded: red
    grown = d.deform(vpffd.edits.scale(d.lattice.control_points, 1.3), preserve_volume=False)
    img = vpffd.render_comparison(d, grown, size=SIZE, lattice_style="none")
    _, big = panels(img, 2)
    assert -blue_minus_red(big, mesh_mask(big)) > 40


def test_colour_map_is_centred_at_one():
    c = volume_change_colors([0.5, 1.0, 2.0, 0.0, -1.0], limit=2.0)
    assert c[0, 2] > c[0, 0] and c[2, 0] > c[2, 2]  # blue compressed, red expanded
    assert np.ptp(c[1]) < 0.01  # neutral grey at 1
    np.testing.assert_allclose(c[3], FOLD_COLOR)
    np.testing.assert_allclose(c[4], FOLD_COLOR)
    np.testing.assert_allclose(c[0], volume_change_colors([0.25], 2.0)[0])  # saturates at 1 / limit
    with pytest.raises(vpffd.InvalidInputError):
        volume_change_colors([1.0], limit=1.0)


def test_fold_colour_shows():
    """The third layer of control points pushed below the second folds the space
    between them (det J < 0): those vertices are drawn in the fold colour."""
    mesh = vpffd.shapes.icosphere(3)
    lat = vpffd.Lattice.around(mesh, shape=(4, 4, 4), degree=2)
    d = vpffd.Deformer(mesh, lat)
    P = lat.control_points.copy()
    P[:, :, 2, 2] -= 1.5  # z layers -1.1, -0.55, 0.55, 1.1: the third goes to -0.95
    r = d.deform(P, preserve_volume=False)
    detj = comparison.local_volume_change(d, P)
    assert (detj <= 0).any()
    img = vpffd.render_comparison(d, r, size=SIZE, lattice_style="none", up="z")
    fold = (FOLD_COLOR * 255).astype(int)
    _, deformed = panels(img, 2)
    near_fold = (np.abs(deformed - fold).max(axis=2) < 60) & (deformed[:, :, 1] > deformed[:, :, 0] + 60)
    assert near_fold.sum() > 20


def test_lattice_styles(squashed):
    d, r = squashed
    none = vpffd.render_comparison(d, r, size=SIZE, lattice_style="none")
    faint = vpffd.render_comparison(d, r, size=SIZE, lattice_style="faint")
    full = vpffd.render_comparison(d, r, size=SIZE, lattice_style="full")
    # The mesh's own silhouette, from the same camera: with "none" nothing is drawn
    # outside it (1 pixel of anti-aliasing aside); the lattice styles draw there.
    cap, ph, pw, x0 = layout(none, 3)
    V = [d.mesh.vertices, d.ffd(r.control_points - r.offsets), r.vertices]
    cam = comparison.fit_camera(np.concatenate(V), up="z", size=(pw, ph))
    for i, (p_none, p_faint, p_full) in enumerate(zip(panels(none, 3), panels(faint, 3), panels(full, 3))):
        _, depth = vpffd.render(vpffd.Mesh(V[i], d.mesh.faces), cam, size=(pw, ph), return_depth=True)
        sil = np.isfinite(depth)
        grown = sil.copy()
        grown[1:] |= sil[:-1]
        grown[:-1] |= sil[1:]
        grown[:, 1:] |= grown[:, :-1].copy()
        grown[:, :-1] |= grown[:, 1:].copy()
        assert not mesh_mask(p_none)[~grown].any(), i
        assert mesh_mask(p_faint)[~grown].sum() > 50, i
        assert mesh_mask(p_full)[~grown].sum() > mesh_mask(p_faint)[~grown].sum(), i
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.render_comparison(d, r, size=SIZE, lattice_style="bold")


def _standing(axis):
    """A ball with its lower 20 % cut flat along ``axis``: a model standing on a base."""
    m = vpffd.shapes.icosphere(4)
    V = m.vertices.copy()
    k = "xyz".index(axis)
    across = [i for i in range(3) if i != k]
    V[:, across] *= (1.1 - 0.5 * V[:, k])[:, None]  # wide at the bottom, narrow at the top
    V[:, k] = np.maximum(V[:, k], -0.6)
    return vpffd.Mesh(V, m.faces)


@pytest.mark.parametrize("axis", ["y", "z", "x"])
def test_up_axis_guessed_from_a_base(axis):
    up, why = comparison.guess_up_axis(_standing(axis))
    assert up == axis and "base" in why


def test_up_axis_from_file_convention():
    ball = vpffd.shapes.icosphere(3)  # no base: the file decides
    assert comparison.guess_up_axis(ball, "scan.ply")[0] == "y"
    assert comparison.guess_up_axis(ball, "part.STL")[0] == "z"
    assert comparison.guess_up_axis(ball, "x.obj.gz")[0] == "y"
    assert comparison.guess_up_axis(ball)[0] == "z"


def test_up_axis_points_up_in_the_picture():
    """A y-up model standing on its base, wide below and narrow above: with up
    guessed, the wide part is at the bottom of the picture."""
    m = _standing("y")
    lat = vpffd.Lattice.around(m, shape=(4, 4, 4))
    d = vpffd.Deformer(m, lat)
    r = d.deform(lat.control_points, preserve_volume=False)
    img = vpffd.render_comparison(d, r, size=(400, 300), lattice_style="none", color="none")
    rest = mesh_mask(panels(img, 2)[0])
    rows = np.nonzero(rest.any(axis=1))[0]
    top, bottom = rows.min(), rows.max()
    # horizontal scale 1.1 - 0.5 y: 1.4 at the base (y = -0.6), 0.6 at the top; the
    # row a fifth of the way from either end is about that much wider below
    below, above = bottom - (bottom - top) // 5, top + (bottom - top) // 5
    assert rest[below].sum() > 1.5 * rest[above].sum()


def test_bad_arguments(squashed):
    d, r = squashed
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.render_comparison(d.mesh, r)  # no lattice
    with pytest.raises(TypeError):
        vpffd.render_comparison(d, "result")
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.render_comparison(d, r, up="w")
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.render_comparison(d, r, color="rainbow")
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.render_comparison(d, r, size=(20, 20))


def test_cli_render_and_up(tmp_path, capsys):
    from vpffd.cli.main import main
    if not vpffd.io.FORMATS:
        pytest.skip("built without OpenMesh")
    src = tmp_path / "standing.off"
    vpffd.save_mesh(src, _standing("y"))
    out = tmp_path / "o.png"
    assert main(["deform", str(src), str(tmp_path / "o.off"), "--squash", "0.6", "--preserve", "xz",
                 "--lattice", "5", "--render", str(out), "--size", "600x240", "--lattice-style", "none"]) == 0
    text = capsys.readouterr().out
    assert "up axis y" in text and "squash 0.6 along y" in text
    img = vpffd.load_png(out)
    assert img.shape == (240, 600, 3)
    assert all(mesh_mask(p).mean() > 0.15 for p in panels(img, 3))
    # --up given: no guess printed, and the edits follow it
    assert main(["deform", str(src), str(tmp_path / "o.off"), "--squash", "0.6", "--up", "z", "--lattice", "5"]) == 0
    text = capsys.readouterr().out
    assert "guessed" not in text and "squash 0.6 along z" in text
