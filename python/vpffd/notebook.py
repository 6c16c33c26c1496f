"""Pictures for Jupyter: ``_repr_png_`` of Mesh, Lattice and DeformResult.

Each object draws itself with the Embree renderer (``vpffd.render``) at a small
size, with a caption naming its volume when Pillow is installed to draw the
text. Without Embree the methods return None and Jupyter falls back to the
text ``repr``; nothing here is imported before a notebook asks for a picture.
"""
from __future__ import annotations

import os
import tempfile

import numpy as np

from . import _core

SIZE = (360, 270)
_CAPTION_HEIGHT = 16


def _png(image) -> bytes:
    """PNG bytes of an (H, W, 3) uint8 image, through vpffd.save_png."""
    from ._png import save_png
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "repr.png")
        save_png(path, image)
        with open(path, "rb") as f:
            return f.read()


def _captioned(image, lines) -> np.ndarray:
    """The image with text lines drawn on a white strip below it (Pillow), or as is without Pillow."""
    try:
        from PIL import Image, ImageDraw
    except ImportError:
        return image
    h, w = image.shape[:2]
    canvas = Image.new("RGB", (w, h + _CAPTION_HEIGHT * len(lines) + 4), (255, 255, 255))
    canvas.paste(Image.fromarray(np.ascontiguousarray(image)), (0, 0))
    draw = ImageDraw.Draw(canvas)
    for i, text in enumerate(lines):
        draw.text((6, h + 2 + i * _CAPTION_HEIGHT), text, fill=(20, 20, 20))
    return np.asarray(canvas)


def picture(mesh, lines, lattice=None, control_points=None, size=SIZE):
    """PNG bytes of ``mesh`` (optionally with a lattice's control points) captioned
    with ``lines``; None when this build has no renderer (no Embree)."""
    if not _core.has_embree:
        return None
    from .rendering import render
    image = render(mesh, lattice=lattice, control_points=control_points, size=size, point_radius=2.0)
    return _png(_captioned(image, lines))


def volume_text(mesh) -> str:
    """"volume 4.18879" for a closed mesh, "open mesh: no volume" otherwise."""
    return f"volume {mesh.volume:.6g}" if mesh.is_closed else "open mesh: no volume"


def mesh_png(mesh):
    return picture(mesh, [f"{mesh.n_vertices:,} vertices, {mesh.n_faces:,} faces, {volume_text(mesh)}"])


def lattice_png(lattice):
    """The lattice's box surface mapped through its current control points, with the points."""
    from .mesh import Mesh
    from .shapes import box
    cube = box(12)
    rest = lattice.box_min + (cube.vertices + 0.5) * (lattice.box_max - lattice.box_min)
    deformed = Mesh(lattice.deform_points(rest), cube.faces)
    rest_volume = float(np.prod(lattice.box_max - lattice.box_min))
    nu, nv, nw = lattice.shape
    return picture(deformed, [f"lattice {nu}x{nv}x{nw}, degree {tuple(lattice.degree)}",
                              f"box volume {deformed.volume:.6g} (rest {rest_volume:.6g})"], lattice=lattice)


def result_png(result):
    if getattr(result, "faces", None) is None:
        return None
    from .mesh import Mesh
    mesh = Mesh(result.vertices, result.faces)
    lines = [f"volume {result.volume:.10g} (rest {result.rest_volume:.10g})",
             f"plain FFD {result.volume_before:.6g} ({100 * result.volume_change_before:+.3g} %)"]
    return picture(mesh, lines, control_points=result.control_points)
