"""``vpffd deform --multires`` with --drag, --render and --backend vulkan."""
import importlib.util

import numpy as np
import pytest

import vpffd
from vpffd.cli.main import main

needs_io = pytest.mark.skipif(not vpffd._core.has_openmesh, reason="mesh files need OpenMesh")
HAS_RENDER = vpffd._core.has_embree and importlib.util.find_spec("PIL") is not None


def _vulkan_device():
    from test_vulkan import DEVICE
    return DEVICE


@pytest.fixture
def bumpy(tmp_path):
    vpffd.save_mesh(tmp_path / "in.ply", vpffd.shapes.bumpy_sphere(3))
    return tmp_path / "in.ply"


@needs_io
def test_multires_drag(bumpy, tmp_path, capsys):
    src = vpffd.load_mesh(bumpy)
    mr = vpffd.Multires(src, smoothing=5)
    k = int(np.argmax(mr.base.vertices[:, 2]))
    p = mr.base.vertices[k]
    drag = ",".join(repr(float(x)) for x in p) + ":0.2,0.1,1.3"
    assert main(["deform", str(bumpy), str(tmp_path / "out.ply"), "--multires", "5", f"--drag={drag}",
                 "--lattice", "6", "--up", "z"]) == 0
    out = capsys.readouterr().out
    assert "dragged points to their targets" in out and "base volume kept" in out
    got = vpffd.load_mesh(tmp_path / "out.ply").vertices
    lat = vpffd.Lattice.around(src, shape=6)
    want = vpffd.MultiresDeformer(mr, lat).deform(constraints=[(p, (0.2, 0.1, 1.3))])
    assert want.constraint_error < 1e-9
    np.testing.assert_allclose(got, want.vertices, atol=1e-6)
    # The fine vertex over the dragged base point went (nearly) with it.
    assert np.linalg.norm(got[k] - [0.2, 0.1, 1.3]) < 0.1


@pytest.mark.skipif(not (vpffd._core.has_openmesh and HAS_RENDER), reason="needs OpenMesh and Embree")
def test_multires_render(bumpy, tmp_path, capsys, monkeypatch):
    import vpffd._files as files
    written = []
    real = files.write_bytes
    monkeypatch.setattr(files, "write_bytes", lambda path, data, what="write": (written.append(str(path)),
                                                                               real(path, data, what))[1])
    assert main(["deform", str(bumpy), str(tmp_path / "out.ply"), "--multires", "5", "--squash", "0.5",
                 "--lattice", "5", "--up", "z", "--render", str(tmp_path / "o.png"), "--size", "600x300"]) == 0
    assert "picture:" in capsys.readouterr().out
    assert str(tmp_path / "o.png") in written  # through the atomic writer
    from PIL import Image
    img = np.asarray(Image.open(tmp_path / "o.png").convert("RGB"))
    assert img.shape == (300, 600, 3)
    # Three panels, each showing its mesh below the captions.
    for i in range(3):
        panel = img[120:, 200 * i:200 * (i + 1)]
        assert (panel.min(axis=2) < 230).mean() > 0.05, i


@needs_io
def test_multires_vulkan(bumpy, tmp_path, capsys, monkeypatch):
    dev = _vulkan_device()
    if dev is None:
        pytest.skip("no Vulkan backend in this build or no suitable device")
    monkeypatch.setenv("VPFFD_VULKAN_DEVICE", str(dev["index"]))
    for extra in ([], ["--drag=0,0,1:0.2,0.1,1.3"]):
        for name, backend in (("g.ply", "vulkan"), ("c.ply", "serial")):
            assert main(["deform", str(bumpy), str(tmp_path / name), "--multires", "5", "--twist", "40",
                         "--lattice", "6", "--up", "z", "--backend", backend, *extra]) == 0
        assert "vulkan backend" in capsys.readouterr().out
        g, c = vpffd.load_mesh(tmp_path / "g.ply").vertices, vpffd.load_mesh(tmp_path / "c.ply").vertices
        # The device frame against the CPU one: a few 1e-6 of the diagonal (gpu_bounds.py), float32 files.
        assert np.abs(g - c).max() < 1e-4 * np.linalg.norm(np.ptp(c, axis=0)), extra


@needs_io
def test_multires_render_needs_png_name(bumpy, tmp_path, capsys):
    assert main(["deform", str(bumpy), str(tmp_path / "o.ply"), "--multires", "5", "--render",
                 str(tmp_path / "o.jpg")]) == 2
    assert "--render" in capsys.readouterr().err
