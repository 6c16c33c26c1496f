"""PNG files without an imaging library (zlib + struct)."""
from __future__ import annotations

import struct
import zlib

import numpy as np

from . import _core

InvalidInputError = _core.InvalidInputError


def save_png(path, image) -> None:
    """Writes an (H, W, 3) or (H, W, 4) uint8 image (or (H, W) grey) as a PNG file
    (zlib + struct; no imaging library needed). Float images in [0, 1] are scaled."""
    import os
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"save_png: expected a file name, got {type(path).__name__}")
    img = np.asarray(image)
    if img.dtype != np.uint8:
        if not np.issubdtype(img.dtype, np.floating):
            raise TypeError(f"save_png: expected uint8 or float in [0, 1], got dtype {img.dtype}")
        img = (np.clip(np.nan_to_num(img), 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    if img.ndim == 2:
        img = img[:, :, None]
    if img.ndim != 3 or img.shape[2] not in (1, 3, 4) or img.shape[0] < 1 or img.shape[1] < 1:
        raise InvalidInputError(f"save_png: expected (H, W), (H, W, 3) or (H, W, 4), got shape {np.shape(image)}")
    h, w, c = img.shape
    color_type = {1: 0, 3: 2, 4: 6}[c]
    raw = np.concatenate([np.zeros((h, 1), np.uint8), np.ascontiguousarray(img).reshape(h, w * c)], axis=1)

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, color_type, 0, 0, 0)) +
           chunk(b"IDAT", zlib.compress(raw.tobytes(), 6)) + chunk(b"IEND", b""))
    from ._files import write_bytes
    write_bytes(path, png, "save_png")  # checked, atomic: a failed write leaves the old file


def load_png(path) -> np.ndarray:
    """Reads an 8-bit, non-interlaced grey/RGB/RGBA PNG (as save_png writes) into an
    (H, W, C) uint8 array."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise _core.MeshIOError(f"load_png: '{path}': not a PNG file")
    pos, idat, hdr = 8, [], None
    while pos + 8 <= len(data):
        n, tag = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if tag == b"IHDR":
            hdr = struct.unpack(">IIBBBBB", body)
        elif tag == b"IDAT":
            idat.append(body)
        elif tag == b"IEND":
            break
        pos += 12 + n
    if hdr is None:
        raise _core.MeshIOError(f"load_png: '{path}': no IHDR chunk")
    w, h, depth, ctype, _, _, interlace = hdr
    if depth != 8 or interlace or ctype not in (0, 2, 6):
        raise _core.MeshIOError(f"load_png: '{path}': only 8-bit non-interlaced grey/RGB/RGBA is supported")
    c = {0: 1, 2: 3, 6: 4}[ctype]
    try:
        raw = np.frombuffer(zlib.decompress(b"".join(idat)), np.uint8).reshape(h, 1 + w * c)
    except (zlib.error, ValueError):
        raise _core.MeshIOError(f"load_png: '{path}': truncated or corrupt image data") from None
    out = np.zeros((h, w * c), np.int32)
    for y in range(h):
        ft, line = raw[y, 0], raw[y, 1:].astype(np.int32)
        prev = out[y - 1] if y else np.zeros(w * c, np.int32)
        if ft == 0:
            cur = line
        elif ft == 2:
            cur = (line + prev) & 255
        else:  # Sub, Average, Paeth need the left neighbour: per pixel
            cur = np.zeros(w * c, np.int32)
            for i in range(w * c):
                a = cur[i - c] if i >= c else 0
                b = prev[i]
                cc = prev[i - c] if i >= c else 0
                if ft == 1:
                    pred = a
                elif ft == 3:
                    pred = (a + b) // 2
                else:
                    p = a + b - cc
                    pa, pb, pc = abs(p - a), abs(p - b), abs(p - cc)
                    pred = a if pa <= pb and pa <= pc else (b if pb <= pc else cc)
                cur[i] = (line[i] + pred) & 255
        out[y] = cur
    return out.astype(np.uint8).reshape(h, w, c)
