"""What every animated scene of the demo writes the same way: a folder of numbered
frames (stale ones of a longer earlier run removed), the animated GIF, and work
run under an optional progress bar."""
from __future__ import annotations

import re
from contextlib import contextmanager
from pathlib import Path

from .._files import replaced_path


def line_height(draw) -> int:
    """Pixels from one caption line to the next: the default font's full height
    (ascender to descender, from its text boxes) plus 2 pixels between lines."""
    box = draw.textbbox((0, 0), "Ag|()", anchor="la")
    return box[3] - min(box[1], 0) + 2


def label(img, lines, first: int = 0):
    """Draws ``lines`` of text at the top left of the PIL image ``img``, line
    ``first`` onwards (empty strings keep their line free); returns it."""
    label_boxes(img, lines, first)
    return img


def label_boxes(img, lines, first: int = 0) -> list:
    """``label``, returning the (left, top, right, bottom) pixel box of every line drawn."""
    from PIL import ImageDraw
    d = ImageDraw.Draw(img)
    step = line_height(d)
    boxes = []
    for i, text in enumerate(lines):
        if text:
            xy = (5, 3 + (first + i) * step)
            d.text(xy, text, fill=(20, 20, 20), anchor="la")
            boxes.append(d.textbbox(xy, text, anchor="la"))
    return boxes


def frame_dir(out: Path, key: str, frames: int) -> Path:
    """``out/key``, created, without the ``frame_NNN.png`` files this run of
    ``frames`` frames will not overwrite (only files with our names are removed)."""
    fdir = Path(out) / key
    fdir.mkdir(parents=True, exist_ok=True)
    for old in fdir.glob("frame_*.png"):
        m = re.fullmatch(r"frame_(\d+)\.png", old.name)
        if m and old.name == f"frame_{int(m.group(1)):03d}.png" and int(m.group(1)) >= frames and old.is_file():
            old.unlink()
    return fdir


def save_frame(fdir: Path, f: int, image) -> Path:
    path = fdir / f"frame_{f:03d}.png"
    with replaced_path(path, "save_frame") as tmp:
        image.save(tmp)
    return path


def write_gif(images, path: Path, seconds_per_frame: float) -> Path:
    """An endlessly looping GIF of the PIL ``images`` (128-colour palettes), at least
    20 ms per frame."""
    from PIL import Image
    pal = [g.convert("P", palette=Image.ADAPTIVE, colors=128) for g in images]
    ms = max(int(round(1000 * seconds_per_frame)), 20)
    with replaced_path(path, "write_gif") as tmp:
        pal[0].save(tmp, save_all=True, append_images=pal[1:], duration=ms, loop=0, optimize=False)
    return path


@contextmanager
def bar(progress, label: str, total: int):
    """``progress(label, total)`` as a context (None when there is no progress)."""
    b = progress(label, total) if progress else None
    try:
        yield b
    finally:
        if b:
            b.close()
