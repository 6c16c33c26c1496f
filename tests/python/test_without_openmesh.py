"""A build without OpenMesh (e.g. `pip install .` on a machine with only Eigen and a
compiler) reads every format and writes every format but OM with vpffd's own code,
and refuses writing .om with the package to install. Runs only in such a build:

    pip install . -Ccmake.define.CMAKE_DISABLE_FIND_PACKAGE_OpenMesh=ON
"""
import numpy as np
import pytest

import vpffd

pytestmark = pytest.mark.skipif(vpffd._core.has_openmesh or not vpffd._core.has_mesh_io,
                                reason="needs a build with mesh file reading but without OpenMesh")


def test_own_readers_work(tmp_path):
    (tmp_path / "tet.ply").write_text(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\n"
        "element face 4\nproperty list uchar int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n")
    (tmp_path / "tet.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    (tmp_path / "tet.off").write_text("OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n")
    (tmp_path / "tet.stl").write_text("solid t\n" + "".join(
        f"facet normal 0 0 0\nouter loop\nvertex {a}\nvertex {b}\nvertex {c}\nendloop\nendfacet\n"
        for a, b, c in [("0 0 0", "0 1 0", "1 0 0"), ("0 0 0", "1 0 0", "0 0 1"), ("0 0 0", "0 0 1", "0 1 0"),
                        ("1 0 0", "0 1 0", "0 0 1")]) + "endsolid t\n")
    for ext in ("ply", "obj", "off", "stl"):
        m = vpffd.load_mesh(tmp_path / f"tet.{ext}")
        assert (m.n_vertices, m.n_faces) == (4, 4)
        assert m.volume == pytest.approx(1 / 6, rel=1e-12)


@pytest.mark.parametrize("ext,binary", [("ply", None), ("ply", False), ("obj", None), ("off", None),
                                        ("off", True), ("stl", None), ("stl", False)])
def test_every_format_but_om_is_written(tmp_path, ext, binary):
    ico = vpffd.shapes.icosphere(1)
    vpffd.save_mesh(tmp_path / f"out.{ext}", ico, binary=binary)
    back = vpffd.load_mesh(tmp_path / f"out.{ext}")
    assert (back.n_vertices, back.n_faces) == (ico.n_vertices, ico.n_faces)
    if ext != "stl":
        np.testing.assert_array_equal(back.faces, ico.faces)


def test_om_writing_names_the_package(tmp_path):
    ico = vpffd.shapes.icosphere(1)
    with pytest.raises(vpffd.BackendUnavailableError, match="libopenmesh-dev"):
        vpffd.save_mesh(tmp_path / "out.om", ico)
    assert not (tmp_path / "out.om").exists()
    # The C++ layer refuses too, for callers of vpffd._core.
    with pytest.raises(vpffd.BackendUnavailableError, match="libopenmesh-dev.*\\.om"):
        vpffd._core.write_mesh(str(tmp_path / "out.om"), ico.vertices, ico.faces)
    assert not (tmp_path / "out.om").exists()


def test_cli_refuses_om_before_any_work(tmp_path, capsys):
    from vpffd.cli.main import main
    src = tmp_path / "in.obj"
    src.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    assert main(["deform", str(src), str(tmp_path / "out.om"), "--squash", "0.5"]) == 1
    err = capsys.readouterr().err
    assert "libopenmesh-dev" in err and "out.om" in err
    assert not (tmp_path / "out.om").exists()
    assert main(["deform", str(src), str(tmp_path / "out.ply"), "--squash", "0.5"]) == 0
    assert vpffd.load_mesh(tmp_path / "out.ply").n_faces == 4
