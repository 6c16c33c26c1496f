"""The demo's multiresolution scene (vpffd.cli.multires_scene): numbers and pictures."""
import io

import numpy as np
import pytest

import vpffd
from vpffd.cli import multires_scene as ms


@pytest.fixture(scope="module")
def scene():
    return ms.run(ms.bent_body(quick=True))


def test_volumes_and_normal_errors(scene):
    r = scene.results
    n = scene.frames
    assert r["ffd"].shape == r["multires"].shape == (n, scene.mesh.n_vertices, 3)
    # The corrected FFD and the multiresolution base keep their volumes exactly: the
    # correction's own error is ~F u (F faces, u = 1.1e-16), far below 1e-12.
    assert np.all(r["ffd_error"] < 1e-12) and np.all(r["base_error"] < 1e-12)
    # The plain FFD loses volume as the bend grows; the rebuilt fine mesh does not keep
    # its own volume exactly (only its base's), and says so.
    assert np.all(np.diff(r["plain_change"]) < 0) and r["plain_change"][-1] < -0.05
    assert r["multires_error"][-1] > 1e-6
    # Frame 0 is the rest shape: the approximate normals are the rest normals, equal
    # to the recomputed ones up to rounding; then the error grows with the bend and
    # stays within the paper's 5 degrees for an extreme edit (mean).
    assert r["angles"][0].max() < 1e-6
    means = r["angles"].mean(axis=1)
    assert np.all(np.diff(means) > 0) and 0.1 < means[-1] < 5.0
    # The details: kept by the multiresolution edit, changed (a little: a bend) by the FFD.
    d = r["details"]
    assert d["multires"].height_change_max < 1e-12 and d["plain"].height_change_mean > 0.01


def test_table_and_csv(scene, tmp_path):
    s = io.StringIO()
    ms.table(scene, s)
    text = s.getvalue()
    assert "bent to 150 deg" in text and text.count("°") == 2 * scene.frames
    ms.write_csv(scene, tmp_path / "m.csv")
    rows = (tmp_path / "m.csv").read_text().splitlines()
    assert len(rows) == scene.frames + 1 and rows[0].startswith("frame,time_s,bend_deg")


@pytest.mark.skipif(not vpffd._core.has_embree, reason="needs the Embree renderer")
def test_pictures_have_three_panels_and_a_coloured_error_map(scene, tmp_path):
    pytest.importorskip("PIL")
    from PIL import Image
    files = ms.render(scene, tmp_path, (120, 90))
    assert (tmp_path / "multires.gif").exists() and len(files) == scene.frames + 1
    img = np.asarray(Image.open(tmp_path / "multires" / f"frame_{scene.frames - 1:03d}.png").convert("RGB"))
    assert img.shape == (90, 360, 3)
    panels = [img[20:, 120 * i:120 * (i + 1)].reshape(-1, 3).astype(int) for i in range(3)]
    # Every panel shows the mesh (enough non-white pixels); the first two are grey
    # (r = g = b), the third is coloured by the viridis map (not grey).
    for p in panels:
        assert (p.min(axis=1) < 235).mean() > 0.15
    chroma = [np.ptp(p, axis=1) for p in panels]
    assert np.percentile(chroma[0], 99) <= 3 and np.percentile(chroma[1], 99) <= 3
    assert np.percentile(chroma[2], 90) > 30
