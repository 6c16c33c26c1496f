"""Notebook pictures (_repr_png_), the example notebook, the trimesh round trip."""
import json
import sys
from pathlib import Path

import numpy as np
import pytest

import vpffd
from vpffd import _core

NOTEBOOK = Path(__file__).resolve().parents[2] / "examples" / "notebooks" / "quickstart.ipynb"
needs_embree = pytest.mark.skipif(not _core.has_embree, reason="this build has no Embree renderer")


def png_image(data, tmp_path):
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    p = tmp_path / "x.png"
    p.write_bytes(data)
    return vpffd.load_png(p)


@pytest.fixture(scope="module")
def squashed():
    mesh = vpffd.shapes.icosphere(2)
    lat = vpffd.Lattice.around(mesh, shape=(4, 4, 4))
    lat.control_points = vpffd.squash(lat.control_points, 0.6)
    return mesh, lat, vpffd.Deformer(mesh, lat).deform()


def test_example_notebook_runs_top_to_bottom(capsys):
    nb = json.loads(NOTEBOOK.read_text())
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    assert len(code) >= 4
    ns = {"__name__": "__notebook__"}
    for i, c in enumerate(code):
        exec(compile("".join(c["source"]), f"{NOTEBOOK.name}[code cell {i}]", "exec"), ns)
    assert ns["kept"].volume_error < 1e-12
    assert "vpffd:" in capsys.readouterr().out


@needs_embree
def test_pictures(squashed, tmp_path):
    mesh, lat, r = squashed
    pil = pytest.importorskip("PIL")  # the caption strip needs Pillow
    assert pil
    for obj, captions in ((mesh, 1), (lat, 2), (r, 2)):
        img = png_image(obj._repr_png_(), tmp_path)
        w, h = vpffd.notebook.SIZE
        assert img.shape[1] == w and img.shape[0] > h  # the caption strip is below the picture
        # the render is not blank: the mesh's grey shading differs from the white background
        assert (img[:h] < 200).any()
        # the caption strip has dark text pixels in it
        assert (img[h:] < 100).any()


@needs_embree
def test_pictures_without_pillow(squashed, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "PIL", None)  # import PIL raises ImportError
    img = png_image(squashed[0]._repr_png_(), tmp_path)
    assert img.shape[:2] == vpffd.notebook.SIZE[::-1]


def test_no_picture_without_embree(squashed, monkeypatch):
    monkeypatch.setattr(_core, "has_embree", False)
    mesh, lat, r = squashed
    assert mesh._repr_png_() is None and lat._repr_png_() is None and r._repr_png_() is None


def test_caption_names_the_volume(squashed):
    from vpffd import notebook
    mesh, _lat, r = squashed
    assert notebook.volume_text(mesh) == f"volume {mesh.volume:.6g}"
    open_mesh = vpffd.Mesh(mesh.vertices, mesh.faces[1:])
    assert notebook.volume_text(open_mesh) == "open mesh: no volume"


def test_trimesh_round_trip(squashed):
    trimesh = pytest.importorskip("trimesh")
    mesh, _lat, r = squashed
    t = r.to_trimesh()
    assert isinstance(t, trimesh.Trimesh)
    assert np.array_equal(t.vertices, r.vertices) and np.array_equal(t.faces, r.faces)
    assert t.is_watertight
    # trimesh sums the same 320 triangles in another way: each sum's rounding is at most
    # ~320 * 2^-53 of the volume (4e-14), so 1e-13 bounds their difference
    assert abs(t.volume - r.volume) <= 1e-13 * abs(r.volume)
    back = vpffd.Mesh.from_any(t)
    assert np.array_equal(back.vertices, r.vertices) and np.array_equal(back.faces, mesh.faces)
    assert np.array_equal(mesh.to_trimesh().vertices, mesh.vertices)
    t.vertices[0] += 1.0  # the Trimesh owns copies: the result is untouched
    assert not np.array_equal(t.vertices[0], r.vertices[0])


def test_to_trimesh_without_trimesh_names_the_package(squashed, monkeypatch):
    monkeypatch.setitem(sys.modules, "trimesh", None)
    with pytest.raises(ImportError, match="pip install trimesh"):
        squashed[2].to_trimesh()
    with pytest.raises(ImportError, match="pip install trimesh"):
        squashed[0].to_trimesh()
