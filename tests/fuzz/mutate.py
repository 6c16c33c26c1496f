"""Mutations of seed files: byte-level noise plus format-aware damage to headers and counts."""
from __future__ import annotations

import gzip
import random
import re
import struct

HUGE_TEXT = [b"2147483647", b"2147483648", b"4294967295", b"4294967296", b"-1", b"-2147483648",
             b"99999999999999999999", b"1e400", b"nan", b"-inf", b"0", b"1000000000", b"65536", b"0x10"]
HUGE_U32 = [0xFFFFFFFF, 0x7FFFFFFF, 0x80000000, 0x10000000, 0x00FFFFFF, 0x40000000, 0, 1, 65535, 65536]
ODD_BYTES = [b"\xff", b"\x80", b"\xc3", b"\x00", b"\r", b"\n", b"\t", b" ", b"#", b"\xe9\x00"]
HEADER_WORDS = [b"ply", b"format ascii", b"format ascii 1.0", b"format binary_little_endian 1.0",
                b"format binary_big_endian 1.0", b"format binary_big_endian", b"element vertex 4294967295",
                b"element face 2147483647", b"property list uint int vertex_indices", b"property double x",
                b"property list uchar float vertex_indices", b"end_header", b"OFF BINARY", b"OFF", b"NOFF",
                b"COFF", b"4OFF", b"STOFF", b"solid", b"endsolid", b"facet normal", b"vertex", b"v", b"vn",
                b"f", b"OM", b"OMT", b"OMP"]


def _bit_flip(rng, b: bytearray):
    for _ in range(rng.randint(1, 8)):
        i = rng.randrange(len(b))
        b[i] ^= 1 << rng.randrange(8)


def _set_byte(rng, b: bytearray):
    for _ in range(rng.randint(1, 4)):
        b[rng.randrange(len(b))] = rng.choice([0, 0xFF, 0x7F, 0x80, 0x20, 0x0A, rng.randrange(256)])


def _insert(rng, b: bytearray):
    i = rng.randrange(len(b) + 1)
    if rng.random() < 0.5:
        b[i:i] = rng.choice(ODD_BYTES) * rng.randint(1, 3)
    else:
        b[i:i] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 16)))


def _delete(rng, b: bytearray):
    i = rng.randrange(len(b))
    del b[i:i + rng.randint(1, 16)]


def _truncate(rng, b: bytearray):
    del b[rng.randrange(len(b)):]


def _duplicate(rng, b: bytearray):
    i = rng.randrange(len(b))
    j = min(len(b), i + rng.randint(1, 64))
    k = rng.randrange(len(b) + 1)
    b[k:k] = b[i:j]


def _huge_text_number(rng, b: bytearray):
    nums = list(re.finditer(rb"-?\d+(\.\d+)?(e-?\d+)?", bytes(b)))
    if not nums:
        return _bit_flip(rng, b)
    # Header counts come first; bias towards them.
    m = nums[min(int(rng.expovariate(0.3)), len(nums) - 1)]
    b[m.start():m.end()] = rng.choice(HUGE_TEXT)


def _huge_binary_field(rng, b: bytearray):
    if len(b) < 4:
        return _bit_flip(rng, b)
    # Counts live near the start (OFF/STL/OM headers) or right after a text header.
    end = bytes(b).find(b"end_header\n")
    lo = end + 11 if end >= 0 and rng.random() < 0.5 else 0
    hi = min(len(b) - 4, lo + (96 if rng.random() < 0.7 else len(b)))
    if hi < lo:
        return _bit_flip(rng, b)
    i = rng.randint(lo, hi)
    if rng.random() < 0.5:
        i -= i % 4
    fmt = rng.choice(["<I", ">I", "<H"])
    v = rng.choice(HUGE_U32) & (0xFFFF if fmt == "<H" else 0xFFFFFFFF)
    b[i:i + struct.calcsize(fmt)] = struct.pack(fmt, v)


def _swap_lines(rng, b: bytearray):
    lines = bytes(b).split(b"\n")
    if len(lines) < 3:
        return _bit_flip(rng, b)
    n = min(len(lines), 12 if rng.random() < 0.7 else len(lines))
    i, j = rng.randrange(n), rng.randrange(n)
    lines[i], lines[j] = lines[j], lines[i]
    b[:] = b"\n".join(lines)


def _header_word(rng, b: bytearray):
    lines = bytes(b).split(b"\n")
    i = rng.randrange(min(len(lines), 12))
    w = rng.choice(HEADER_WORDS)
    if rng.random() < 0.5:
        lines[i] = w
    else:
        lines.insert(i, w)
    b[:] = b"\n".join(lines)


def _random_bytes(rng, b: bytearray):
    keep = rng.randrange(0, min(len(b), 16) + 1)  # sometimes keep the magic
    b[keep:] = bytes(rng.randrange(256) for _ in range(rng.randint(0, 256)))


MUTATIONS = [_bit_flip, _set_byte, _insert, _delete, _truncate, _duplicate, _huge_text_number,
             _huge_binary_field, _swap_lines, _header_word, _random_bytes]


def mutate(rng: random.Random, ext: str, data: bytes) -> bytes:
    """One to three mutations of ``data``; a .gz seed is mutated inside (mostly) or as compressed bytes."""
    if ext.endswith(".gz") and rng.random() < 0.8:
        inner = mutate(rng, ext[:-3], gzip.decompress(data))
        return gzip.compress(inner, compresslevel=1, mtime=0)
    b = bytearray(data)
    for _ in range(rng.choice([1, 1, 1, 2, 3])):
        if not b:
            b += bytes([rng.randrange(256)])
        rng.choice(MUTATIONS)(rng, b)
    return bytes(b)
