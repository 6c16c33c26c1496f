"""Mesh readers on hostile input (issue 9): every case once crashed, hung, ran out of
memory or raised the wrong error. Loads that could crash or hang run in a child
process, so that a regression fails this test instead of killing the suite."""
import gzip
import os
import struct
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import vpffd

pytestmark = pytest.mark.skipif(not vpffd._core.has_mesh_io, reason="built without mesh file I/O")
needs_openmesh = pytest.mark.skipif(not vpffd._core.has_openmesh, reason="writing .om needs OpenMesh")

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fuzz"))
import seeds  # noqa: E402  (tests/fuzz: the fuzzer's seed builders)

CHILD = textwrap.dedent("""
    import os, resource, sys
    import vpffd
    path, as_mb = os.fsencode(sys.argv[1]), int(sys.argv[2])
    if as_mb:
        with open("/proc/self/statm") as fh:
            mapped = int(fh.read().split()[0]) * resource.getpagesize()
        resource.setrlimit(resource.RLIMIT_AS, (mapped + as_mb * 2**20,) * 2)
    try:
        m = vpffd.load_mesh(path)
        print("OK", m.n_vertices, m.n_faces)
    except vpffd.MeshIOError as e:
        print("MeshIOError", str(e))
    except BaseException as e:
        print("OTHER", type(e).__name__, str(e))
""")


def load_in_child(path, as_mb=512, timeout=60):
    """(outcome, message) of vpffd.load_mesh(path) in a fresh process with a capped address space.

    outcome: OK, MeshIOError, OTHER (another exception), CRASH (a signal or exit
    status without output) or HANG (no answer within ``timeout`` seconds).
    """
    try:
        r = subprocess.run([sys.executable, "-c", CHILD, os.fsdecode(path), str(as_mb)], capture_output=True,
                           timeout=timeout, env=dict(os.environ, OMP_NUM_THREADS="1"))
    except subprocess.TimeoutExpired:
        return "HANG", ""
    out = r.stdout.decode(errors="replace").strip()
    if r.returncode != 0 or not out:
        return "CRASH", f"exit {r.returncode}: {r.stderr.decode(errors='replace')[-300:]}"
    outcome, _, msg = out.partition(" ")
    return outcome, msg


def expect_error(path, *words, **kw):
    outcome, msg = load_in_child(path, **kw)
    assert outcome == "MeshIOError", (outcome, msg)
    assert os.path.basename(os.fsdecode(path)) in msg or "\\x" in msg, msg
    for w in words:
        assert w.lower() in msg.lower(), (w, msg)
    return msg


def chunk(entity, typ, dim, bits, is_float):
    """An OM chunk header (see read_om.cpp for the bit layout)."""
    return struct.pack("<H", (entity << 2) | (typ << 5) | (is_float << 10) | ((dim - 1) << 11) | (bits << 14))


def om_writer_file(tmp_path):
    """An OM file from OpenMesh's own writer (halfedge topology, OM >= 2.0)."""
    p = tmp_path / "w.om"
    vpffd.save_mesh(p, vpffd.Mesh(np.array(seeds.TET_V), np.array(seeds.TET_F, np.int32)))
    return bytearray(p.read_bytes())


def find_chunk(data, entity, typ):
    """Offset of the data of the first chunk (entity, type) in an OM file written without names."""
    nV, nF, nE = struct.unpack_from("<3I", data, 4)
    at = 16
    while at + 2 <= len(data):
        (h,) = struct.unpack_from("<H", data, at)
        e, t, dim, bits, flt = (h >> 2) & 7, (h >> 5) & 15, ((h >> 11) & 7) + 1, (h >> 14) & 3, (h >> 10) & 1
        if e == 7:
            break
        if (e, t) == (entity, typ):
            return at + 2, bits
        n = {0: nV, 2: nF, 4: nE, 6: 2 * nE, 1: 1}[e]
        if t == 7:
            size = n * (1 << bits) * (6 if e == 6 else 1) // (2 if e == 6 else 1)
        else:
            size = n * dim * ((4 << bits) if flt else (1 << bits))
        at += 2 + size
    raise AssertionError("chunk not found")


# --- OM --------------------------------------------------------------------------
def test_om_position_chunk_with_wrong_dimension(tmp_path):
    # OpenMesh's OMReader asserted (abort) on dimensions(chunk_header_) == 3.
    tet = seeds.om_v1(seeds.TET_V, seeds.TET_F)
    bad = bytearray(tet)
    bad[16:18] = chunk(0, 0, 2, 0, 1)
    p = tmp_path / "dim2.om"
    p.write_bytes(bytes(bad))
    expect_error(p, "3 float32 or float64")


@needs_openmesh
def test_om_face_halfedge_out_of_range(tmp_path):
    # read_mesh walked OpenMesh's face loops and segfaulted on this.
    data = om_writer_file(tmp_path)
    at, bits = find_chunk(data, 2, 7)
    data[at:at + (1 << bits)] = (0x7FFFFFFF).to_bytes(4, "little")[: 1 << bits]
    p = tmp_path / "face_he.om"
    p.write_bytes(bytes(data))
    expect_error(p, "corrupt topology")


@needs_openmesh
def test_om_next_halfedge_cycle_is_refused(tmp_path):
    # A `next` pointing to itself: a face loop that never closes at its start.
    data = om_writer_file(tmp_path)
    at, bits = find_chunk(data, 6, 7)
    isz = 1 << bits
    data[at:at + isz] = (1).to_bytes(isz, "little")  # next(0) = 1
    data[at + 3 * isz:at + 4 * isz] = (1).to_bytes(isz, "little")  # next(1) = 1
    p = tmp_path / "cycle.om"
    p.write_bytes(bytes(data))
    expect_error(p, "corrupt topology")


@pytest.mark.parametrize("field", [0, 1, 2])
def test_om_huge_counts_are_refused_before_allocating(tmp_path, field):
    # A 16-byte header asking for 2^32 - 1 elements grew the process to gigabytes
    # and let MemoryError('std::bad_alloc') escape without the file name.
    tet = bytearray(seeds.om_v1(seeds.TET_V, seeds.TET_F))
    struct.pack_into("<I", tet, 4 + 4 * field, 0xFFFFFFFF)
    p = tmp_path / f"huge{field}.om"
    p.write_bytes(bytes(tet))
    expect_error(p, as_mb=256)


@needs_openmesh
def test_om_round_trip_both_versions(tmp_path):
    for name, data in [("v1.om", seeds.om_v1(seeds.CUBE_V, seeds.CUBE_F)),
                       ("v1d.om", seeds.om_v1(seeds.TET_V, seeds.TET_F, double=True))]:
        (tmp_path / name).write_bytes(data)
        m = vpffd.load_mesh(tmp_path / name)
        assert m.n_vertices in (4, 8) and m.check().is_volume
    (tmp_path / "w.om").write_bytes(om_writer_file(tmp_path))
    m = vpffd.load_mesh(tmp_path / "w.om")
    np.testing.assert_array_equal(m.vertices, np.array(seeds.TET_V))


# --- OFF ---------------------------------------------------------------------------
@pytest.mark.parametrize("text_header", [False, True])
def test_binary_off_huge_counts_are_refused_before_allocating(tmp_path, text_header):
    # 59 bytes announcing 2^32 - 1 vertices grew to 4 GiB before failing.
    body = struct.pack("<3I", 0xFFFFFFFF, 1, 0) + struct.pack("<9f", *range(9)) + struct.pack("<4I", 3, 0, 1, 2)
    head = b"OFF BINARY\n"
    p = tmp_path / "huge.off"
    p.write_bytes(head + body)
    if text_header:  # an ASCII-looking file whose header says BINARY
        p.write_bytes(b"OFF BINARY\n4294967295 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    msg = expect_error(p, "header announces", as_mb=256)
    assert "4294967295" in msg or "bytes" in msg


def test_binary_off_round_trip_and_errors(tmp_path):
    p = tmp_path / "b.off"
    p.write_bytes(seeds.off_binary(seeds.CUBE_V, seeds.CUBE_F, normals=True))
    m, n = vpffd.load_mesh(p, return_normals=True)
    assert (m.n_vertices, m.n_faces) == (8, 12) and m.check().is_volume
    np.testing.assert_array_equal(n, np.tile([0.0, 0.0, 1.0], (8, 1)))
    data = bytearray(seeds.off_binary(seeds.TET_V, seeds.TET_F))
    struct.pack_into("<I", data, len(data) - 4, 99)
    p.write_bytes(bytes(data))
    with pytest.raises(vpffd.MeshIOError, match="refers to vertex 99"):
        vpffd.load_mesh(p)
    p.write_bytes(bytes(data[:-2]))
    with pytest.raises(vpffd.MeshIOError, match="truncated"):
        vpffd.load_mesh(p)


def test_ascii_off_counts_larger_than_the_file(tmp_path):
    p = tmp_path / "big.off"
    p.write_bytes(b"OFF\n2000000000 2000000000 0\n0 0 0\n")
    with pytest.raises(vpffd.MeshIOError, match="at least"):
        vpffd.load_mesh(p)


# --- PLY ---------------------------------------------------------------------------
def test_ply_format_without_version_does_not_hang(tmp_path):
    # OpenMesh's PLY can_u_read looped forever on this header.
    p = tmp_path / "nover.ply"
    p.write_bytes(seeds.ply(seeds.TET_V, seeds.TET_F).replace(b"format ascii 1.0", b"format ascii"))
    expect_error(p, "format", timeout=30)


def test_ply_header_bytes_that_are_not_utf8(tmp_path):
    # OpenMesh's message with the raw bytes escaped as UnicodeDecodeError.
    p = tmp_path / "latin.ply"
    p.write_bytes(seeds.ply(seeds.TET_V, seeds.TET_F).replace(b"comment seed", b"\xff\xfe caf\xe9"))
    msg = expect_error(p, "\\xff")
    assert "\ufffd" not in msg


def test_binary_ply_list_count_past_the_end(tmp_path):
    data = seeds.ply(seeds.TET_V, seeds.TET_F, "binary_little_endian", "int", "int")
    at = data.index(b"end_header\n") + 11 + 4 * 12
    bad = bytearray(data)
    struct.pack_into("<i", bad, at, 0x7FFFFFFF)
    p = tmp_path / "list.ply"
    p.write_bytes(bytes(bad))
    expect_error(p, "list of 2147483647")


def test_ply_big_endian_and_int_lists_load(tmp_path):
    for fmt in ("binary_big_endian", "binary_little_endian"):
        p = tmp_path / f"{fmt}.ply"
        p.write_bytes(seeds.ply(seeds.CUBE_V, seeds.CUBE_F, fmt, "uint", "int"))
        m = vpffd.load_mesh(p)
        np.testing.assert_array_equal(m.vertices, np.array(seeds.CUBE_V))
        assert m.n_faces == 12


# --- memory and gzip -------------------------------------------------------------
def test_gzip_bomb_is_refused(tmp_path):
    # 256 MiB of zeros after an OFF header: a few hundred kilobytes compressed.
    p = tmp_path / "bomb.off.gz"
    with gzip.open(p, "wb", compresslevel=9) as fh:
        fh.write(b"OFF\n3 1 0\n")
        zeros = bytes(1 << 20)
        for _ in range(256):
            fh.write(zeros)
    assert p.stat().st_size < 2 << 20
    expect_error(p, "decompresses to more than", as_mb=512)


# --- file names --------------------------------------------------------------------
def test_names_that_are_not_utf8_load_and_save(tmp_path):
    mesh = vpffd.Mesh(np.array(seeds.TET_V), np.array(seeds.TET_F, np.int32))
    raw = os.fsencode(tmp_path) + b"/m\xe9sh\xff.off"
    vpffd.save_mesh(raw, mesh)
    for name in (raw, os.fsdecode(raw), Path(os.fsdecode(raw))):
        np.testing.assert_array_equal(vpffd.load_mesh(name).faces, mesh.faces)
    with pytest.raises(vpffd.MeshIOError, match=r"no such file") as e:
        vpffd.load_mesh(os.fsencode(tmp_path) + b"/gone\xff.ply")
    assert "gone\\xff.ply" in str(e.value)


@pytest.mark.parametrize("kind", [str, bytes])
def test_embedded_nul_is_refused(tmp_path, kind):
    mesh = vpffd.Mesh(np.array(seeds.TET_V), np.array(seeds.TET_F, np.int32))
    vpffd.save_mesh(tmp_path / "a.obj", mesh)
    name = str(tmp_path / "a.obj") + "\0.xyz"
    path = name if kind is str else os.fsencode(name)
    with pytest.raises(vpffd.MeshIOError, match="NUL") as e:
        vpffd.load_mesh(path)
    assert "a.obj\\x00.xyz" in str(e.value) and "unknown format" not in str(e.value)
    with pytest.raises(vpffd.MeshIOError, match="NUL"):
        vpffd.save_mesh(path, mesh)


def test_other_path_types_are_type_errors():
    for bad in (42, None, 1.5, ["a.obj"]):
        with pytest.raises(TypeError):
            vpffd.load_mesh(bad)
