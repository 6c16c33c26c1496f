"""Mesh files through OpenMesh: round trips per format, .gz, bad files and arguments."""
import gzip
import os
import warnings
from pathlib import Path

import numpy as np
import pytest

import vpffd

pytestmark = pytest.mark.skipif(not vpffd._core.has_openmesh, reason="built without OpenMesh")

SHARED = Path(__file__).resolve().parents[2].parent / "shared/data/meshes"
F32 = 1e-7  # OpenMesh's OBJ/OFF/PLY/STL writers store float32 coordinates


@pytest.fixture(scope="module")
def sphere():
    return vpffd.shapes.icosphere(2)


def _match_by_position(a, b):
    """Index map from b's vertices to a's (STL readers merge and reorder them)."""
    ia = np.lexsort(np.round(a.vertices, 6).T)
    ib = np.lexsort(np.round(b.vertices, 6).T)
    m = np.empty(len(ib), int)
    m[ib] = ia
    return m


@pytest.mark.parametrize("ext,binary", [("obj", None), ("off", False), ("off", True), ("ply", False),
                                        ("ply", True), ("stl", False), ("stl", True), ("om", None)])
def test_round_trip(tmp_path, sphere, ext, binary):
    p = tmp_path / f"s.{ext}"
    vpffd.save_mesh(p, sphere, binary=binary)
    back = vpffd.load_mesh(p)
    assert back.n_vertices == sphere.n_vertices and back.n_faces == sphere.n_faces
    tol = 0.0 if ext == "om" else F32
    if ext == "stl":
        m = _match_by_position(sphere, back)
        np.testing.assert_allclose(back.vertices, sphere.vertices[m], atol=tol)
        faces = {tuple(np.roll(f, -np.argmin(f))) for f in m[back.faces]}
        assert faces == {tuple(np.roll(f, -np.argmin(f))) for f in sphere.faces}
    else:
        np.testing.assert_allclose(back.vertices, sphere.vertices, atol=tol, rtol=0)
        np.testing.assert_array_equal(back.faces, sphere.faces)
    assert back.check().is_volume
    assert abs(back.volume - sphere.volume) <= 1e-6 * sphere.volume


@pytest.mark.parametrize("ext", ["obj", "off", "ply", "om"])
def test_normals_round_trip(tmp_path, sphere, ext):
    n = vpffd.vertex_normals(sphere)
    p = tmp_path / f"n.{ext}"
    vpffd.save_mesh(p, sphere, normals=n)
    back, nb = vpffd.load_mesh(p, return_normals=True)
    assert nb is not None and nb.shape == n.shape
    np.testing.assert_allclose(nb, n, atol=1e-6)


def test_no_normals_gives_none(tmp_path, sphere):
    vpffd.save_mesh(tmp_path / "a.ply", sphere)
    _, n = vpffd.load_mesh(tmp_path / "a.ply", return_normals=True)
    assert n is None


def test_polygons_are_triangulated(tmp_path):
    p = tmp_path / "quad.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4\nf 1 2 5\n")
    m = vpffd.load_mesh(p)
    assert m.n_faces == 3
    np.testing.assert_array_equal(m.faces, [[0, 1, 2], [0, 2, 3], [0, 1, 4]])


def test_gzip_is_transparent(tmp_path, sphere):
    vpffd.save_mesh(tmp_path / "s.ply", sphere)
    (tmp_path / "s.ply.gz").write_bytes(gzip.compress((tmp_path / "s.ply").read_bytes()))
    a, b = vpffd.load_mesh(tmp_path / "s.ply"), vpffd.load_mesh(str(tmp_path / "s.ply.gz"))
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.faces, b.faces)


def test_faces_kept_as_stored(tmp_path):
    # Three faces on one edge: OpenMesh's own mesh would split one off; the
    # reader must return all of them with the original indices.
    p = tmp_path / "fin.off"
    p.write_text("OFF\n5 3 0\n0 0 0\n1 0 0\n0 1 0\n0 -1 0\n0 0 1\n3 0 1 2\n3 1 0 3\n3 0 1 4\n")
    m = vpffd.load_mesh(p)
    assert m.n_vertices == 5
    np.testing.assert_array_equal(m.faces, [[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    assert m.check().nonmanifold_edges == 1


def test_save_accepts_trimesh_like_and_keeps_input(tmp_path, sphere):
    class Like:  # what trimesh and friends look like
        pass
    obj = Like()
    obj.vertices = np.array(sphere.vertices)
    obj.faces = np.array(sphere.faces, dtype=np.int64)
    before = obj.vertices.copy(), obj.faces.copy()
    vpffd.save_mesh(tmp_path / "t.om", obj)
    np.testing.assert_array_equal(obj.vertices, before[0])
    np.testing.assert_array_equal(obj.faces, before[1])
    assert vpffd.load_mesh(tmp_path / "t.om").n_faces == sphere.n_faces


def test_save_nonmanifold_warns(tmp_path):
    V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]]
    F = [[0, 1, 2], [1, 0, 3], [0, 1, 4]]
    with pytest.warns(UserWarning, match="non-manifold"):
        vpffd.save_mesh(tmp_path / "fin.ply", (V, F))


def test_load_orient_flips_inward_mesh(tmp_path, sphere):
    vpffd.save_mesh(tmp_path / "in.om", sphere.flipped())
    m = vpffd.load_mesh(tmp_path / "in.om")
    assert m.check().is_inward
    o = vpffd.load_mesh(tmp_path / "in.om", orient=True)
    assert o.check().is_volume


# --- bad files --------------------------------------------------------------------
def _bad(tmp_path, sphere):
    vpffd.save_mesh(tmp_path / "ok.ply", sphere)
    vpffd.save_mesh(tmp_path / "ok.stl", sphere)
    vpffd.save_mesh(tmp_path / "ok.off", sphere)
    ply = (tmp_path / "ok.ply").read_bytes()
    stl = (tmp_path / "ok.stl").read_bytes()
    off = (tmp_path / "ok.off").read_text()
    rng = np.random.default_rng(1)
    files = {
        "empty.ply": b"",
        "truncated.ply": ply[: len(ply) // 2],
        "short_by_one.ply": ply[:-1],
        "header_only.ply": ply[:60],
        "garbage.ply": rng.bytes(2000),
        "garbage.off": rng.bytes(2000),
        "garbage.om": rng.bytes(2000),
        "garbage.stl": rng.bytes(2000),
        "text.obj": b"this is not a mesh\n",
        "truncated.stl": stl[: len(stl) // 2],
        "truncated.off": off[: len(off) // 2].encode(),
        "points.off": b"OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n",
        "bad_index.off": b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
        "bad_index.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
        "truncated.ply.gz": gzip.compress(ply)[:300],
        "mesh.xyz": b"0 0 0\n",
        "noext": b"0 0 0\n",
    }
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    return list(files) + ["missing.ply"]


def test_bad_files_raise_mesh_io_error_naming_the_file(tmp_path, sphere):
    (tmp_path / "folder.ply").mkdir()
    for name in _bad(tmp_path, sphere) + ["folder.ply"]:
        p = tmp_path / name
        with pytest.raises(vpffd.MeshIOError) as e:
            vpffd.load_mesh(p)
        assert name in str(e.value), (name, str(e.value))
        assert isinstance(e.value, OSError)


def test_truncated_messages_say_truncated(tmp_path, sphere):
    _bad(tmp_path, sphere)
    for name in ["truncated.ply", "truncated.stl", "truncated.off", "truncated.ply.gz"]:
        with pytest.raises(vpffd.MeshIOError, match="(?i)truncated|end of file"):
            vpffd.load_mesh(tmp_path / name)
    with pytest.raises(vpffd.MeshIOError, match="no such file"):
        vpffd.load_mesh(tmp_path / "missing.ply")
    with pytest.raises(vpffd.MeshIOError, match="empty"):
        vpffd.load_mesh(tmp_path / "empty.ply")
    with pytest.raises(vpffd.MeshIOError, match="unknown format"):
        vpffd.load_mesh(tmp_path / "mesh.xyz")


def test_bad_arguments(tmp_path, sphere):
    with pytest.raises(TypeError):
        vpffd.load_mesh(42)
    with pytest.raises(TypeError):
        vpffd.save_mesh(None, sphere)
    with pytest.raises(TypeError):
        vpffd.save_mesh(tmp_path / "a.ply", "not a mesh")
    with pytest.raises(vpffd.MeshIOError, match="does not exist"):
        vpffd.save_mesh(tmp_path / "nope" / "a.ply", sphere)
    with pytest.raises(vpffd.MeshIOError, match="compressed"):
        vpffd.save_mesh(tmp_path / "a.ply.gz", sphere)
    with pytest.raises(vpffd.MeshIOError, match="unknown format"):
        vpffd.save_mesh(tmp_path / "a.xyz", sphere)
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.save_mesh(tmp_path / "a.obj", sphere, binary=True)
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.save_mesh(tmp_path / "a.ply", sphere, normals=np.zeros((3, 3)))
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.save_mesh(tmp_path / "a.ply", sphere, normals=np.full((sphere.n_vertices, 3), np.nan))
    with pytest.raises(TypeError):
        vpffd.save_mesh(tmp_path / "a.ply", sphere, binary="yes")


@pytest.mark.skipif(not SHARED.is_dir(), reason="needs ../shared/data/meshes")
def test_shared_gz_matches_manifest_sizes():
    m = vpffd.load_mesh(SHARED / "BADINPUT_dragon_vrip_raw_unwelded.ply.gz")
    assert (m.n_vertices, m.n_faces) == (437645, 871414)
