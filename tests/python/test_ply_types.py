"""PLY files of every type the format names read right: list counts and face indices
of each of the twelve integer type names, coordinates of every scalar type, extra
properties and list properties on any element, ASCII and both binary byte orders.
The files are made by a small writer here, so each case knows what it must read."""
import struct

import numpy as np
import pytest

import vpffd

pytestmark = pytest.mark.skipif(not vpffd._core.has_mesh_io, reason="built without mesh file I/O")

CODE = {"char": "b", "uchar": "B", "short": "h", "ushort": "H", "int": "i", "uint": "I", "float": "f",
        "double": "d", "int8": "b", "uint8": "B", "int16": "h", "uint16": "H", "int32": "i", "uint32": "I",
        "float32": "f", "float64": "d"}
INTS = [t for t in CODE if CODE[t] in "bBhHiI"]
FORMATS = ["ascii", "binary_little_endian", "binary_big_endian"]

# A tetrahedron with small integer coordinates (exact in every type) and outward faces.
V = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2]], float)
F = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]])


def ply(fmt, coord="float", count="uchar", index="int", vertex_extra=(), face_extra=(), other=None, faces=F):
    """Bytes of a PLY file. vertex_extra / face_extra: (header line, value(s)) pairs
    appended to each record (a value list for a list property, written with its count)."""
    head = ["ply", f"format {fmt} 1.0", "comment made by test_ply_types"]
    head += [f"element vertex {len(V)}"] + [f"property {coord} {a}" for a in "xyz"]
    head += [h for h, _ in vertex_extra]
    head += [f"element face {len(faces)}", f"property list {count} {index} vertex_indices"]
    head += [h for h, _ in face_extra]
    if other:
        head += [f"element {other[0]} {len(other[2])}", other[1]]
    head.append("end_header")
    out = ("\n".join(head) + "\n").encode()
    end = ">" if fmt == "binary_big_endian" else "<"

    def values(typ, vals):
        if fmt == "ascii":
            return (" ".join(str(v) for v in vals) + " ").encode()
        return struct.pack(end + CODE[typ] * len(vals), *vals)

    def extra(extras):
        b = b""
        for h, v in extras:
            parts = h.split()
            if parts[1] == "list":
                b += values(parts[2], [len(v)]) + values(parts[3], v)
            else:
                b += values(parts[1], [v])
        return b

    def rec(b):
        return b.rstrip(b" ") + b"\n" if fmt == "ascii" else b

    for p in V:
        c = [int(x) for x in p] if CODE[coord] in "bBhHiI" else [float(x) for x in p]
        out += rec(values(coord, c) + extra(vertex_extra))
    for f in faces:
        out += rec(values(count, [len(f)]) + values(index, [int(i) for i in f]) + extra(face_extra))
    if other:
        typ = other[1].split()[1]
        for v in other[2]:
            out += rec(values(typ, [v]))
    return out


def load(tmp_path, data, name="t.ply"):
    p = tmp_path / name
    p.write_bytes(data)
    return vpffd.load_mesh(p)


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("count", INTS)
def test_every_count_and_index_type(tmp_path, fmt, count):
    for index in INTS:
        m = load(tmp_path, ply(fmt, count=count, index=index))
        assert np.array_equal(m.vertices, V) and np.array_equal(m.faces, F), (count, index)


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("coord", list(CODE))
def test_every_coordinate_type(tmp_path, fmt, coord):
    data = ply(fmt, coord=coord)
    if CODE[coord] in "bBhHiI":
        with pytest.warns(UserWarning, match="stored as integers"):
            m = load(tmp_path, data)
    else:
        m = load(tmp_path, data)
    assert np.array_equal(m.vertices, V) and np.array_equal(m.faces, F)
    assert m.volume == pytest.approx(8 / 6)


@pytest.mark.parametrize("fmt", FORMATS)
def test_extra_and_list_properties_are_skipped(tmp_path, fmt):
    data = ply(fmt, vertex_extra=[("property uchar red", 200), ("property list uint8 float texcoords", [0.5, 0.25]),
                                  ("property double quality", 1.5)],
               face_extra=[("property list ushort int16 neighbours", [1, 2, 3]), ("property float area", 2.0)],
               other=("material", "property int id", [7, 8]))
    m = load(tmp_path, data)
    assert np.array_equal(m.vertices, V) and np.array_equal(m.faces, F)


@pytest.mark.parametrize("fmt", FORMATS)
def test_polygons_and_normals(tmp_path, fmt):
    # A quad and a triangle: the quad becomes a fan of two, both counted.
    data = ply(fmt, vertex_extra=[("property float nx", 0.0), ("property float ny", 0.0), ("property float nz", 1.0)],
               faces=[[0, 1, 2, 3], [0, 1, 3]])
    p = tmp_path / "q.ply"
    p.write_bytes(data)
    d = vpffd._core.read_mesh(bytes(p))
    assert d["polygons"] == 2 and d["triangulated_polygons"] == 1
    assert d["faces"].tolist() == [[0, 1, 2], [0, 2, 3], [0, 1, 3]]
    assert np.array_equal(d["normals"], np.tile([0.0, 0.0, 1.0], (4, 1)))


def test_big_counts_in_a_tiny_file_are_refused_at_once(tmp_path):
    """Counts the file's bytes cannot hold are refused before anything is allocated
    (checked in a child whose address space is capped at 256 MiB above its start)."""
    import subprocess
    import sys
    import textwrap
    cases = {
        "binary_int_coords.ply": (b"ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\n"
                                  b"property int x\nproperty int y\nproperty int z\nelement face 2000000000\n"
                                  b"property list int int vertex_indices\nend_header\n" + b"\x01" * 200),
        "ascii.ply": (b"ply\nformat ascii 1.0\nelement vertex 2000000000\nproperty short x\nproperty short y\n"
                      b"property short z\nelement face 1\nproperty list char uint vertex_indices\nend_header\n"
                      + b"1 2 3\n" * 30),
        "list.ply": (b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                     b"property float z\nelement face 1\nproperty list uint uint vertex_indices\nend_header\n"
                     + b"\0" * 36 + b"\x7f\xff\xff\xff" + b"\0" * 12),
    }
    for name, data in cases.items():
        (tmp_path / name).write_bytes(data)
    child = textwrap.dedent("""
        import resource, sys
        import vpffd
        with open("/proc/self/statm") as fh:
            mapped = int(fh.read().split()[0]) * resource.getpagesize()
        resource.setrlimit(resource.RLIMIT_AS, (mapped + 256 * 2**20,) * 2)
        for path in sys.argv[1:]:
            try:
                vpffd.load_mesh(path)
                print("OK", path)
            except vpffd.MeshIOError as e:
                print("MeshIOError", e)
    """)
    r = subprocess.run([sys.executable, "-c", child, *map(str, sorted(tmp_path.iterdir()))], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert len(lines) == 3 and all(line.startswith("MeshIOError") for line in lines), r.stdout
    assert all("truncated" in line for line in lines), r.stdout


def test_no_library_chatter_on_stderr(tmp_path, capfd):
    load(tmp_path, ply("binary_little_endian", coord="double", count="int32", index="uint16"))
    out, err = capfd.readouterr()
    assert err == ""


@pytest.mark.parametrize("fmt", FORMATS)
def test_partial_normals_are_ignored(tmp_path, fmt):
    """nx and ny without nz (a fuzzer's find: the reader wrote normals it had not made room for)."""
    p = tmp_path / "n.ply"
    p.write_bytes(ply(fmt, vertex_extra=[("property float nx", 0.0), ("property float ny", 1.0)]))
    m, N = vpffd.load_mesh(p, return_normals=True)
    assert N is None and np.array_equal(m.vertices, V)


def test_real_scans_read_as_another_reader_reads_them(shared_meshes, tmp_path):
    """Every PLY of the developer mesh set (scans with holes, non-manifold and unwelded
    ones included) gives exactly trimesh's vertices and faces (process=False: as stored)."""
    import gzip

    trimesh = pytest.importorskip("trimesh")
    files = sorted(shared_meshes.glob("*.ply")) + sorted(shared_meshes.glob("*.ply.gz"))
    assert files
    for p in files:
        plain = p
        if p.suffix == ".gz":
            plain = tmp_path / p.stem
            plain.write_bytes(gzip.decompress(p.read_bytes()))
        m = vpffd.load_mesh(p)
        t = trimesh.load(plain, process=False)
        assert np.array_equal(m.vertices, np.asarray(t.vertices)), p.name
        assert np.array_equal(m.faces, np.asarray(t.faces)), p.name
