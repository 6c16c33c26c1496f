"""What a deformation does to a decomposition's details (vpffd.detail_change) and the
demo's still picture of it (the paper's Fig. 6)."""
import importlib.util
import io

import numpy as np
import pytest

import vpffd
from vpffd.cli import multires_scene as ms
from vpffd.details import detail_change

HAS_RENDER = vpffd._core.has_embree and importlib.util.find_spec("PIL") is not None


@pytest.fixture(scope="module")
def scene():
    return ms.detail_scene(quick=True)


def test_multires_keeps_the_details_and_the_ffd_does_not(scene):
    mr, plain = scene.numbers["multires"], scene.numbers["plain"]
    # Multiresolution: every detail has its rest height |d| and stands along the
    # deformed base normal, to rounding.
    assert mr.height_change_max < 1e-12 and mr.angle_max_deg < 1e-6
    # The plain FFD of the fine mesh squashes and tilts them: by a lot, measured.
    assert plain.height_change_mean > 0.15 and plain.angle_mean_deg > 5.0
    assert plain.n_measured == mr.n_measured > 50


def test_the_numbers_follow_the_edit():
    """Not constants: the identity changes nothing, a milder squash less."""
    mesh = vpffd.shapes.bumpy_sphere(3, amplitude=0.1, frequency=7.0)
    lat = vpffd.Lattice.around(mesh, shape=5)
    md = vpffd.MultiresDeformer(vpffd.Multires(mesh, smoothing=10), lat, backend="serial")
    ident = detail_change(md, mesh.vertices)
    assert ident.height_change_max < 1e-12 and ident.angle_max_deg < 1e-6
    d = vpffd.Deformer(mesh, lat, backend="serial")
    mild, strong = (detail_change(md, d.ffd(P), P) for P in
                    (vpffd.edits.squash(lat.control_points, f, axis="z") for f in (0.8, 0.4)))
    assert 0 < mild.height_change_mean < strong.height_change_mean
    assert 0 < mild.angle_mean_deg < strong.angle_mean_deg
    with pytest.raises(vpffd.InvalidInputError, match="shape"):
        detail_change(md, mesh.vertices[:-1])
    with pytest.raises(vpffd.InvalidInputError, match="min_height"):
        detail_change(md, mesh.vertices, min_height=0)


def test_detail_table(scene):
    s = io.StringIO()
    ms.detail_table(scene, s)
    text = s.getvalue()
    assert "FFD of the fine mesh" in text and "multiresolution" in text
    assert f"{100 * scene.numbers['plain'].height_change_mean:8.3g} %" in text


@pytest.mark.skipif(not HAS_RENDER, reason="needs the Embree renderer and Pillow")
def test_detail_picture(scene, tmp_path):
    from PIL import Image
    path = ms.write_detail_picture(scene, tmp_path / "d.png", (600, 320))
    img = np.asarray(Image.open(path).convert("RGB"))
    assert img.shape == (320, 600, 3)
    for i in range(3):
        assert (img[150:, 200 * i:200 * (i + 1)].min(axis=2) < 230).mean() > 0.05, i


@pytest.mark.skipif(not HAS_RENDER, reason="needs the Embree renderer and Pillow")
def test_demo_writes_the_picture_and_its_numbers(tmp_path):
    from vpffd.cli.demo import run_demo
    s = io.StringIO()
    r = run_demo(out=tmp_path, quick=True, motion=False, size=(120, 90), stream=s)
    assert tmp_path / "multires_details.png" in r["files"] and (tmp_path / "multires_details.png").is_file()
    assert "squashed to 0.35 of its height" in s.getvalue() and "multires_details.png" in s.getvalue()
