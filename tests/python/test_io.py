"""Mesh files: round trips per format, .gz, bad files and arguments."""
import gzip
import os
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import vpffd

pytestmark = pytest.mark.skipif(not vpffd._core.has_mesh_io, reason="built without mesh file I/O")
needs_openmesh = pytest.mark.skipif(not vpffd._core.has_openmesh, reason="writing .om needs OpenMesh")

SHARED = Path(__file__).resolve().parents[2].parent / "shared/data/meshes"


@pytest.fixture(scope="module")
def sphere():
    return vpffd.shapes.icosphere(2)


def _awkward(sphere):
    """The sphere with coordinates that use every bit of float64 (and a -0.0)."""
    rng = np.random.default_rng(3)
    V = sphere.vertices * np.pi + rng.uniform(-1e-3, 1e-3, sphere.vertices.shape)
    V[0, 0] = -0.0
    return vpffd.Mesh(V, sphere.faces)


# Every format keeps float64 exactly (ASCII with the default 17 digits, binary PLY
# and OM as double), except binary OFF and binary STL, which store float32: there
# each coordinate comes back rounded once to float32, exactly. (OpenMesh's OBJ, OFF,
# PLY and STL writers, used before, stored float32 everywhere: 1e-7 was the
# tolerance then; now the contract is bit for bit.)
@pytest.mark.parametrize("ext,binary", [("obj", None), ("off", False), ("off", True), ("ply", False),
                                        ("ply", True), ("stl", False), ("stl", True),
                                        pytest.param("om", None, marks=needs_openmesh)])
def test_round_trip(tmp_path, sphere, ext, binary):
    mesh = _awkward(sphere)
    p = tmp_path / f"s.{ext}"
    vpffd.save_mesh(p, mesh, binary=binary)
    back = vpffd.load_mesh(p)
    assert back.n_vertices == mesh.n_vertices and back.n_faces == mesh.n_faces
    float32 = ext in ("off", "stl") and binary
    want = mesh.vertices.astype(np.float32).astype(np.float64) if float32 else mesh.vertices
    if ext == "stl":
        # No shared vertices in STL: the reader merges equal positions in the order
        # they first appear, so compare corner by corner.
        np.testing.assert_array_equal(back.vertices[back.faces], want[mesh.faces])
        first_seen = np.unique(mesh.faces.ravel(), return_index=True)[1]
        assert first_seen.size == back.n_vertices
    else:
        assert back.vertices.tobytes() == want.tobytes()  # bit for bit, the sign of -0.0 included
        np.testing.assert_array_equal(back.faces, mesh.faces)
    assert back.check().is_volume
    if not float32:
        assert back.volume == mesh.volume


@pytest.mark.parametrize("ext", ["obj", "off", "ply", pytest.param("om", marks=needs_openmesh)])
def test_normals_round_trip(tmp_path, sphere, ext):
    n = vpffd.vertex_normals(sphere)
    p = tmp_path / f"n.{ext}"
    vpffd.save_mesh(p, sphere, normals=n)
    back, nb = vpffd.load_mesh(p, return_normals=True)
    assert nb is not None and nb.shape == n.shape
    np.testing.assert_array_equal(nb, n)


def test_binary_off_normals_are_float32(tmp_path, sphere):
    n = vpffd.vertex_normals(sphere)
    vpffd.save_mesh(tmp_path / "n.off", sphere, normals=n, binary=True)
    _, nb = vpffd.load_mesh(tmp_path / "n.off", return_normals=True)
    np.testing.assert_array_equal(nb, n.astype(np.float32).astype(np.float64))


def test_ascii_precision_rounds(tmp_path):
    V = np.array([[1 / 3, 0, 0], [1, 0, 0], [0, 1, 2 / 3]])
    vpffd.save_mesh(tmp_path / "p.off", (V, [[0, 1, 2]]), precision=4)
    assert (tmp_path / "p.off").read_text().splitlines()[2:5] == ["0.3333 0 0", "1 0 0", "0 1 0.6667"]
    np.testing.assert_array_equal(vpffd.load_mesh(tmp_path / "p.off").vertices, np.round(V, 4))


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


@needs_openmesh
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


NONMANIFOLD_V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]]
# A fin (three faces on edge 0-1), a face with a repeated corner, one of a single vertex.
NONMANIFOLD_F = [[0, 1, 2], [1, 0, 3], [0, 1, 4], [2, 2, 3], [4, 4, 4]]


@pytest.mark.parametrize("ext,binary", [("obj", None), ("off", False), ("off", True), ("ply", False),
                                        ("ply", True), ("stl", False), ("stl", True)])
def test_nonmanifold_and_repeated_corners_round_trip_unchanged(tmp_path, ext, binary):
    # Only OM goes through a halfedge structure; every other writer stores the faces
    # as given, so nothing is split or dropped and no warning is given.
    p = tmp_path / f"fin.{ext}"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vpffd.save_mesh(p, (NONMANIFOLD_V, NONMANIFOLD_F), binary=binary)
    r = vpffd._core.write_mesh(str(p), np.array(NONMANIFOLD_V, float), np.array(NONMANIFOLD_F, np.int32),
                               binary=-1 if binary is None else int(binary))
    assert (r["split_faces"], r["dropped_faces"]) == (0, 0)
    assert r["vertices_written"] == (3 * len(NONMANIFOLD_F) if ext == "stl" else len(NONMANIFOLD_V))
    back = vpffd.load_mesh(p)
    np.testing.assert_array_equal(back.vertices, NONMANIFOLD_V)  # STL: first-seen order is the original one here
    np.testing.assert_array_equal(back.faces, NONMANIFOLD_F)


@needs_openmesh
def test_save_nonmanifold_om_warns(tmp_path):
    # OM stores OpenMesh's halfedge connectivity, which cannot hold the fin or a
    # repeated corner: the report and the warning say what changed.
    r = vpffd._core.write_mesh(str(tmp_path / "fin.om"), np.array(NONMANIFOLD_V, float),
                               np.array(NONMANIFOLD_F, np.int32))
    assert (r["split_faces"], r["dropped_faces"]) == (1, 2)
    with pytest.warns(UserWarning, match="1 non-manifold faces.*2 faces with a repeated vertex index"):
        vpffd.save_mesh(tmp_path / "fin.om", (NONMANIFOLD_V, NONMANIFOLD_F))


@needs_openmesh
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


# --- strict ASCII parsing: garbage or short data is an error, never a wrong mesh ---
TRI_OFF = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"


def _load_error(tmp_path, name, text):
    p = tmp_path / name
    p.write_bytes(text.encode() if isinstance(text, str) else text)
    with pytest.raises(vpffd.MeshIOError) as e:
        vpffd.load_mesh(p)
    msg = str(e.value)
    assert name in msg, msg
    return msg


@pytest.mark.parametrize("bad,where", [
    ("nan 0 0", "line 3"), ("inf 0 0", "line 3"), ("1e400 0 0", "line 3"), ("-inf 0 0", "line 3")])
def test_off_non_finite_coordinate_names_the_line(tmp_path, bad, where):
    msg = _load_error(tmp_path, "nf.off", TRI_OFF.replace("0 0 0\n", bad + "\n", 1))
    assert where in msg and "non-finite" in msg, msg


@pytest.mark.parametrize("text,expect", [
    (TRI_OFF.replace("1 0 0\n", "1 x 0\n"), r"line 4.*'x' is not a number"),
    (TRI_OFF.replace("1 0 0\n", "1 0\n"), r"line 4.*vertex 1 has 2 numbers"),
    (TRI_OFF.replace("3 0 1 2", "3 0 1 b"), r"line 6.*'b' is not a vertex index"),
    (TRI_OFF.replace("3 0 1 2", "3 0 1"), r"line 6.*announces 3 corners"),
    (TRI_OFF.replace("3 0 1 2", "3 0 1 3"), r"line 6.*refers to vertex 3"),
    ("OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n", r"truncated.*4 vertices"),
    ("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", r"truncated.*2 faces"),
    (TRI_OFF + "3 0 2 1\n", r"line 7.*unexpected data"),
    ("OFF\nthree 1 0\n0 0 0\n", r"line 2.*counts"),
    ("FOO\n3 1 0\n", r"line 1.*OFF header"),
])
def test_off_garbage_and_truncation_raise(tmp_path, text, expect):
    msg = _load_error(tmp_path, "bad.off", text)
    assert re.search(expect, msg), msg


def test_off_variants_still_load(tmp_path):
    # comments, blank lines, CRLF, face colours, counts on the keyword line
    # (and glued to it, as in ModelNet), NOFF normals, COFF vertex colours
    texts = [
        "# a comment\nOFF\n\n3 1 0  # counts\r\n0 0 0\n1 0 0 # x axis\n0 1 0\n3 0 1 2 255 0 0\n",
        "OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        "OFF3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1 2\n",
    ]
    for k, t in enumerate(texts):
        p = tmp_path / f"v{k}.off"
        p.write_text(t)
        m = vpffd.load_mesh(p)
        np.testing.assert_array_equal(m.vertices, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
        np.testing.assert_array_equal(m.faces, [[0, 1, 2]])
    p = tmp_path / "n.off"
    p.write_text("NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n")
    m, n = vpffd.load_mesh(p, return_normals=True)
    np.testing.assert_array_equal(n, [[0, 0, 1]] * 3)


def test_off_keeps_degenerate_faces_and_counts_short_ones(tmp_path):
    p = tmp_path / "d.off"
    p.write_text("OFF\n4 3 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 0 0\n4 0 1 1 2\n2 0 1\n")
    d = vpffd._core.read_mesh(str(p))
    np.testing.assert_array_equal(d["faces"], [[0, 0, 0], [0, 1, 1], [0, 1, 2]])
    assert (d["polygons"], d["triangulated_polygons"], d["skipped_faces"]) == (3, 1, 1)


OBJ_TRI = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


def test_obj_keeps_faces_as_stored(tmp_path):
    # OpenMesh's OBJ reader dropped "f 1 1 1" and turned "f 1 2 2 3" into one
    # triangle; faces now come back as stored, like OFF and PLY.
    p = tmp_path / "d.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1 1 1\nf 1 2 2 3\nf 1 2\nf 3/1 -2/1/1 1//1\n")
    d = vpffd._core.read_mesh(str(p))
    np.testing.assert_array_equal(d["faces"], [[0, 0, 0], [0, 1, 1], [0, 1, 2], [2, 1, 0]])
    assert (d["polygons"], d["triangulated_polygons"], d["skipped_faces"]) == (4, 1, 1)
    off = tmp_path / "d.off"
    off.write_text("OFF\n3 4 0\n0 0 0\n1 0 0\n0 1 0\n3 0 0 0\n4 0 1 1 2\n2 0 1\n3 2 1 0\n")
    np.testing.assert_array_equal(vpffd._core.read_mesh(str(off))["faces"], d["faces"])


@pytest.mark.parametrize("text,expect", [
    (OBJ_TRI.replace("v 1 0 0", "v nan 0 0"), r"line 2.*non-finite"),
    (OBJ_TRI.replace("v 1 0 0", "v 1e400 0 0"), r"line 2.*non-finite"),
    (OBJ_TRI.replace("v 1 0 0", "v 1 x 0"), r"line 2.*'x' is not a number"),
    (OBJ_TRI.replace("v 1 0 0", "v 1 0"), r"line 2.*2 values"),
    (OBJ_TRI.replace("f 1 2 3", "f 1 2 x"), r"line 4.*'x'"),
    (OBJ_TRI.replace("f 1 2 3", "f 1 2 0"), r"line 4.*'0'"),
    (OBJ_TRI.replace("f 1 2 3", "f 1 2 -4"), r"line 4.*refers back"),
    (OBJ_TRI.replace("f 1 2 3", "f 1 2 9"), r"line 4.*vertex 9.*3 vertices"),
    (OBJ_TRI.replace("f 1 2 3", "f 1//2 2//2 3//2"), r"line 4.*normal 2"),
])
def test_obj_garbage_raises_naming_the_line(tmp_path, text, expect):
    msg = _load_error(tmp_path, "bad.obj", text)
    assert re.search(expect, msg), msg


def test_obj_ignores_other_keywords(tmp_path):
    p = tmp_path / "k.obj"
    p.write_text("# c\nmtllib a.mtl\no thing\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\ng grp\nusemtl m\ns off\n"
                 "l 1 2\nf 1/1 2/1 3/1\n")
    m = vpffd.load_mesh(p)
    np.testing.assert_array_equal(m.faces, [[0, 1, 2]])


PLY_HEAD = ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 1\nproperty list uchar int vertex_indices\nend_header\n")
PLY_TRI = PLY_HEAD + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"


@pytest.mark.parametrize("text,expect", [
    (PLY_TRI.replace("1 0 0\n", "nan 0 0\n"), r"line 11.*non-finite"),
    (PLY_TRI.replace("1 0 0\n", "1e400 0 0\n"), r"line 11.*non-finite"),
    (PLY_TRI.replace("1 0 0\n", "1 x 0\n"), r"line 11.*'x' is not a number"),
    (PLY_TRI.replace("1 0 0\n", "1 0\n"), r"line 11.*too few values"),
    (PLY_TRI.replace("1 0 0\n", "1 0 0 0\n"), r"line 11.*4 values"),
    (PLY_TRI.replace("3 0 1 2", "3 0 1"), r"line 13.*too few"),
    (PLY_TRI.replace("3 0 1 2", "3 0 1 2.5"), r"line 13.*not an integer"),
    (PLY_HEAD + "0 0 0\n1 0 0\n", r"truncated.*3 vertex"),
    (PLY_TRI + "3 0 1 2\n", r"line 14.*unexpected data"),
])
def test_ascii_ply_garbage_raises_naming_the_line(tmp_path, text, expect):
    msg = _load_error(tmp_path, "bad.ply", text)
    assert re.search(expect, msg), msg


def test_ascii_ply_still_loads(tmp_path):
    p = tmp_path / "ok.ply"
    p.write_text(PLY_TRI.replace("format ascii 1.0\n", "format ascii 1.0\ncomment made by hand\n"))
    m = vpffd.load_mesh(p)
    np.testing.assert_array_equal(m.vertices, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    np.testing.assert_array_equal(m.faces, [[0, 1, 2]])


STL_TRI = ("solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\n"
           "endfacet\nendsolid t\n")


@pytest.mark.parametrize("text,expect", [
    (STL_TRI.replace("vertex 1 0 0", "vertex 1 x 0"), r"line 5.*'x' is not a number"),
    (STL_TRI.replace("vertex 1 0 0", "vertex nan 0 0"), r"line 5.*non-finite"),
    (STL_TRI.replace("vertex 1 0 0", "vertex 1e400 0 0"), r"line 5.*non-finite"),
    (STL_TRI.replace("vertex 1 0 0\n", ""), r"line 6.*expected 'vertex'|line 6.*endloop|expected 'vertex'"),
    (STL_TRI.replace("facet normal 0 0 1", "facet normal 0 zero 1"), r"line 2.*'zero'"),
])
def test_ascii_stl_garbage_raises_naming_the_line(tmp_path, text, expect):
    msg = _load_error(tmp_path, "bad.stl", text)
    assert re.search(expect, msg), msg


def _stl_binary(triangles, count=None, header=b" " * 80):
    body = b"".join(np.array([0, 0, 1, *t], "<f4").tobytes() + b"\0\0" for t in triangles)
    return header + np.array([len(triangles) if count is None else count], "<u4").tobytes() + body


@pytest.mark.parametrize("binary", [False, True])
def test_stl_merges_equal_positions_in_first_seen_order(tmp_path, binary):
    tris = [[0, 0, 0, 1, 0, 0, 0, 1, 0], [1, 0, 0, -0.0, 0, 0, 0, 0, 1]]
    p = tmp_path / "m.stl"
    if binary:
        p.write_bytes(_stl_binary(tris, header=b"solid - but the size says binary".ljust(80)))
    else:
        p.write_text("solid m\n" + "".join(
            "facet normal 0 0 1\nouter loop\n" + "".join(f"vertex {t[k]} {t[k + 1]} {t[k + 2]}\n" for k in (0, 3, 6))
            + "endloop\nendfacet\n" for t in tris) + "endsolid m\n")
    d = vpffd._core.read_mesh(str(p))
    np.testing.assert_array_equal(d["vertices"], [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    np.testing.assert_array_equal(d["faces"], [[0, 1, 2], [1, 0, 3]])
    assert d["polygons"] == 2


TRI = [0, 0, 0, 1, 0, 0, 0, 1, 0]


@pytest.mark.parametrize("data,expect", [
    (_stl_binary([TRI, TRI])[:-30], r"truncated or not an STL file: the binary header announces 2 triangles "
                                    r"\(184 bytes\), the file has 154 bytes"),
    (_stl_binary([TRI, TRI], count=1), r"announces 1 triangles \(134 bytes\), the file has 184 bytes"),
    (_stl_binary([TRI], count=7), r"truncated or not an STL file: the binary header announces 7 triangles"),
    (b" " * 50, r"truncated: a binary STL needs an 84-byte header"),
    (_stl_binary([[0, 0, 0, np.inf, 0, 0, 0, 1, 0]]), r"triangle 0 \(byte 84\) has a non-finite coordinate"),
    (STL_TRI.replace("vertex 1 0 0", "vertex 1 0").encode(), r"line 5: 'vertex' takes 3 values.*has 2"),
    (STL_TRI.replace("vertex 1 0 0", "vertex 1 0 0 5").encode(), r"line 5: 'vertex' takes 3 values.*has 4"),
    (STL_TRI.replace("endloop", "endloop now").encode(), r"line 7: 'endloop' takes 0 values"),
    (STL_TRI.replace("vertex 1 0 0", "vertex 1 0,5 0").encode(), r"line 5.*'0,5' is not a number"),
    (STL_TRI.replace("outer loop", "outer").encode(), r"line 3: expected 'outer loop'"),
    (STL_TRI[:-11].encode(), r"truncated: it ends where 'endsolid' was expected"),
    (STL_TRI.encode() + b"facet\n", r"line 10: unexpected data after 'endsolid'"),
])
def test_malformed_stl_names_the_problem(tmp_path, data, expect):
    msg = _load_error(tmp_path, "bad.stl", data)
    assert re.search(expect, msg), msg


def test_stl_variants_load(tmp_path):
    # upper case, CRLF, blank lines, a byte-order mark, names, two solids in one file
    text = ("\ufeffSOLID a b\r\n\r\nFACET NORMAL 0 0 0\r\n OUTER LOOP\r\nVERTEX 0 0 0\r\nVERTEX 1 0 0\r\n"
            "VERTEX 0 1 0\r\nENDLOOP\r\nENDFACET\r\nENDSOLID a b\r\n" + STL_TRI)
    p = tmp_path / "v.stl"
    p.write_text(text, encoding="utf-8")
    d = vpffd._core.read_mesh(str(p))
    np.testing.assert_array_equal(d["faces"], [[0, 1, 2], [0, 1, 2]])
    np.testing.assert_array_equal(d["vertices"], [[0, 0, 0], [1, 0, 0], [0, 1, 0]])


def test_binary_stl_and_off_refuse_coordinates_beyond_float32(tmp_path, sphere):
    V = sphere.vertices.copy()
    V[3, 1] = 1e39
    for name in ("big.stl", "big.off"):
        with pytest.raises(vpffd.InvalidInputError, match="float32"):
            vpffd.save_mesh(tmp_path / name, (V, sphere.faces), binary=True)
        assert not (tmp_path / name).exists()
    for name, binary in (("big.stl", False), ("big.ply", True), ("big.obj", None)):
        vpffd.save_mesh(tmp_path / name, (V, sphere.faces), binary=binary)
        assert vpffd.load_mesh(tmp_path / name).vertices.max() == 1e39
