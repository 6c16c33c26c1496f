"""Seed corpus for the mesh-reader fuzzer, generated in code (no binary blobs).

Each seed is a small, valid file of one encoding; ``seeds()`` returns a dict
kind -> list of (extension, bytes). The meshes are tiny on purpose: most of a
mutation then lands in a header, a count or an index, where the readers' bugs
live.
"""
from __future__ import annotations

import gzip
import struct

# A tetrahedron (closed, outward) and a unit cube as quads (polygons -> fans).
TET_V = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]
TET_F = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
CUBE_V = [(x, y, z) for z in (0.0, 1.0) for y in (0.0, 1.0) for x in (0.0, 1.0)]
CUBE_F = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
MESHES = [(TET_V, TET_F), (CUBE_V, CUBE_F)]

KINDS = ("obj", "off", "off_binary", "ply_ascii", "ply_le", "ply_be", "stl_ascii", "stl_binary", "om", "gz")
# Strategies beside the mutants (fuzz_io.inputs): every seed cut at every byte, valid
# PLY files of random types and extra properties, text seeds behind a UTF-8 byte-order
# mark. Files of the last two are valid: their names carry ".valid.", and the worker
# counts a refusal as a finding.
STRATEGIES = ("truncated", "ply_types", "bom")
TEXT_KINDS = ("obj", "off", "ply_ascii", "stl_ascii")  # the text formats (a UTF-8 byte-order mark must not matter)
PLY_CODES = {"char": "b", "uchar": "B", "short": "h", "ushort": "H", "int": "i", "uint": "I", "float": "f",
             "double": "d", "int8": "b", "uint8": "B", "int16": "h", "uint16": "H", "int32": "i", "uint32": "I",
             "float32": "f", "float64": "d"}
PLY_INTS = [t for t, c in PLY_CODES.items() if c in "bBhHiI"]


def obj(V, F, normals=False) -> bytes:
    out = ["# seed", "o thing"]
    out += [f"v {x!r} {y!r} {z!r}" for x, y, z in V]
    if normals:
        out += [f"vn 0 0 1" for _ in V]
        out += ["f " + " ".join(f"{i + 1}//{i + 1}" for i in f) for f in F]
    else:
        out += ["f " + " ".join(str(i + 1) for i in f) for f in F]
    return ("\n".join(out) + "\n").encode()


def off_ascii(V, F, keyword="OFF") -> bytes:
    out = [keyword, f"{len(V)} {len(F)} 0"]
    for v in V:
        out.append(" ".join(repr(x) for x in v) + (" 0 0 1" if keyword.startswith("N") else ""))
    out += [f"{len(f)} " + " ".join(map(str, f)) for f in F]
    return ("\n".join(out) + "\n").encode()


def off_binary(V, F, normals=False) -> bytes:
    """OpenMesh's binary OFF: little-endian uint32 counts, float32 vertices, uint32 faces."""
    b = (b"NOFF BINARY\n" if normals else b"OFF BINARY\n") + struct.pack("<3I", len(V), len(F), 0)
    for v in V:
        b += struct.pack("<3f", *v) + (struct.pack("<3f", 0, 0, 1) if normals else b"")
    for f in F:
        b += struct.pack(f"<{len(f) + 1}I", len(f), *f)
    return b


def ply(V, F, fmt="ascii", index_type="int", count_type="uchar", normals=False, coord_type="float",
        vertex_extra=(), face_extra=()) -> bytes:
    """A PLY file; vertex_extra / face_extra: (type, name, value) scalars or
    ("list", count type, value type, name, values) lists appended to each record."""
    props = ["x", "y", "z"] + (["nx", "ny", "nz"] if normals else [])
    head = ["ply", f"format {fmt} 1.0", "comment seed", f"element vertex {len(V)}"]
    head += [f"property {coord_type if p in 'xyz' else 'float'} {p}" for p in props]
    head += [_ply_prop(x) for x in vertex_extra]
    head += [f"element face {len(F)}", f"property list {count_type} {index_type} vertex_indices"]
    head += [_ply_prop(x) for x in face_extra]
    head.append("end_header")
    h = ("\n".join(head) + "\n").encode()
    ints = PLY_CODES[coord_type] in "bBhHiI"
    coord = (lambda x: int(x)) if ints else (lambda x: x)
    if fmt == "ascii":
        body = [" ".join(repr(coord(x)) for x in v) + (" 0.0 0.0 1.0" if normals else "") + _ply_ascii(vertex_extra)
                for v in V]
        body += [f"{len(f)} " + " ".join(map(str, f)) + _ply_ascii(face_extra) for f in F]
        return h + ("\n".join(body) + "\n").encode()
    e = "<" if fmt == "binary_little_endian" else ">"
    b = bytearray(h)
    for v in V:
        b += struct.pack(e + 3 * PLY_CODES[coord_type], *(coord(x) for x in v))
        b += (struct.pack(e + "3f", 0, 0, 1) if normals else b"") + _ply_binary(e, vertex_extra)
    for f in F:
        b += struct.pack(e + PLY_CODES[count_type], len(f)) + struct.pack(e + PLY_CODES[index_type] * len(f), *f)
        b += _ply_binary(e, face_extra)
    return bytes(b)


def _ply_prop(x) -> str:
    return f"property list {x[1]} {x[2]} {x[3]}" if x[0] == "list" else f"property {x[0]} {x[1]}"


def _ply_ascii(extra) -> str:
    out = ""
    for x in extra:
        out += f" {len(x[4])} " + " ".join(map(str, x[4])) if x[0] == "list" else f" {x[2]}"
    return out


def _ply_binary(e, extra) -> bytes:
    out = b""
    for x in extra:
        if x[0] == "list":
            out += struct.pack(e + PLY_CODES[x[1]], len(x[4])) + struct.pack(e + PLY_CODES[x[2]] * len(x[4]), *x[4])
        else:
            out += struct.pack(e + PLY_CODES[x[0]], x[2])
    return out


def ply_typed(rng) -> bytes:
    """A valid PLY of random encoding, count, index and coordinate types (any of the
    names the format allows), with random extra scalar and list properties."""
    V, F = MESHES[rng.randrange(len(MESHES))]
    fmt = rng.choice(["ascii", "binary_little_endian", "binary_big_endian"])

    def extra(prefix):
        out = []
        for j in range(rng.randrange(3)):
            if rng.random() < 0.5:
                out.append((rng.choice(list(PLY_CODES)), f"{prefix}{j}", rng.randrange(100)))
            else:
                out.append(("list", rng.choice(PLY_INTS), rng.choice(list(PLY_CODES)), f"{prefix}l{j}",
                            [rng.randrange(100) for _ in range(rng.randrange(4))]))
        return out

    return ply(V, F, fmt, index_type=rng.choice(PLY_INTS), count_type=rng.choice(PLY_INTS),
               normals=rng.random() < 0.3, coord_type=rng.choice(list(PLY_CODES)), vertex_extra=extra("v"),
               face_extra=extra("f"))


def _triangles(V, F):
    for f in F:
        for k in range(1, len(f) - 1):
            yield V[f[0]], V[f[k]], V[f[k + 1]]


def stl_ascii(V, F) -> bytes:
    out = ["solid seed"]
    for a, b, c in _triangles(V, F):
        out += ["facet normal 0 0 0", "outer loop"] + [f"vertex {p[0]!r} {p[1]!r} {p[2]!r}" for p in (a, b, c)]
        out += ["endloop", "endfacet"]
    out.append("endsolid seed")
    return ("\n".join(out) + "\n").encode()


def stl_binary(V, F) -> bytes:
    tris = list(_triangles(V, F))
    b = b"binary seed".ljust(80, b" ") + struct.pack("<I", len(tris))
    for t in tris:
        b += struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *p) for p in t) + b"\0\0"
    return b


def om_v1(V, F, double=False) -> bytes:
    """OM version 1.2 (vertex-index faces), written by hand from the chunk layout.

    Chunk header (uint16): bit 1 named, bits 2-4 entity, 5-8 type, 9 signed,
    10 float, 11-13 dim-1, 14-15 size code.
    """
    def chunk(entity, typ, dim, bits, is_float, signed=0):
        return struct.pack("<H", (entity << 2) | (typ << 5) | (signed << 9) | (is_float << 10) | ((dim - 1) << 11)
                           | (bits << 14))
    tri = all(len(f) == 3 for f in F)
    b = b"OM" + (b"T" if tri else b"P") + bytes([(1 << 5) | 2])
    b += struct.pack("<3I", len(V), len(F), 0)
    b += chunk(0, 0, 3, 1 if double else 0, 1)
    for v in V:
        b += struct.pack("<3d" if double else "<3f", *v)
    b += chunk(2, 7, 1, 2, 0)
    for f in F:
        if not tri:
            b += struct.pack("<H", len(f))
        b += struct.pack(f"<{len(f)}I", *f)
    return b


def om_from_writer(V, F, tmpdir) -> list[bytes]:
    """OM files from OpenMesh's own writer (the version it writes today, with halfedge topology)."""
    import numpy as np

    import vpffd
    tris = [t for f in F for t in ([f[0], f[k], f[k + 1]] for k in range(1, len(f) - 1))]
    out = []
    for normals in (False, True):
        p = f"{tmpdir}/seed_{len(V)}_{int(normals)}.om"
        mesh = vpffd.Mesh(np.array(V, float), np.array(tris, np.int32))
        vpffd.save_mesh(p, mesh, normals=np.tile([0.0, 0.0, 1.0], (len(V), 1)) if normals else None)
        with open(p, "rb") as fh:
            out.append(fh.read())
    return out


def seeds(tmpdir: str) -> dict[str, list[tuple[str, bytes]]]:
    s: dict[str, list[tuple[str, bytes]]] = {k: [] for k in KINDS}
    for V, F in MESHES:
        s["obj"] += [("obj", obj(V, F)), ("obj", obj(V, F, normals=True))]
        s["off"] += [("off", off_ascii(V, F)), ("off", off_ascii(V, F, "NOFF"))]
        s["off_binary"] += [("off", off_binary(V, F)), ("off", off_binary(V, F, normals=True))]
        s["ply_ascii"] += [("ply", ply(V, F)), ("ply", ply(V, F, normals=True))]
        for kind, fmt in (("ply_le", "binary_little_endian"), ("ply_be", "binary_big_endian")):
            s[kind] += [("ply", ply(V, F, fmt)), ("ply", ply(V, F, fmt, "uint", "int", normals=True))]
        s["stl_ascii"].append(("stl", stl_ascii(V, F)))
        s["stl_binary"].append(("stl", stl_binary(V, F)))
        s["om"] += [("om", om_v1(V, F)), ("om", om_v1(V, F, double=True))]
        s["om"] += [("om", b) for b in om_from_writer(V, F, tmpdir)]
    for kind in KINDS[:-1]:
        s["gz"] += [(ext + ".gz", gzip.compress(data, mtime=0)) for ext, data in s[kind][:2]]
    return s
