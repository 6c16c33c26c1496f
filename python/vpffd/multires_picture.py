"""The picture that explains multiresolution editing (Marinov, Botsch and Kobbelt, Fig. 6): one edit
of a detailed mesh done two ways, side by side under one camera,

    rest | FFD of the fine mesh | multiresolution (base FFD + details rebuilt)

each deformed panel captioned with what happened to the details (``detail_change``:
how much their height |d| changed and how far they tilted from the deformed base
normal) and with the volumes.
"""
from __future__ import annotations

import numpy as np

from . import _core
from .comparison import _font, fit_camera
from .views import guess_up_axis
from .details import detail_change
from .mesh import Mesh
from .rendering import render

InvalidInputError = _core.InvalidInputError


def detail_captions(deformer, plain, result) -> dict:
    """The measured numbers of the picture: ``{"plain": DetailChange, "multires":
    DetailChange}`` for a plain FFD result of the fine mesh (a ``DeformResult``: its
    vertices and its own control points) and a ``MultiresResult`` of ``deformer``."""
    return {"plain": detail_change(deformer, plain.vertices, plain.control_points),
            "multires": detail_change(deformer, result.vertices, result.control_points)}


def _lines(name, change, volume_note) -> list:
    return [name,
            f"detail height |d|: {100 * change.height_change_mean:.3g} % changed (mean; max "
            f"{100 * change.height_change_max:.2g} %)",
            f"tilt from base normal: {change.angle_mean_deg:.3g} deg (mean; max {change.angle_max_deg:.2g})",
            volume_note]


def _volume_note(error, base_error=None) -> str:
    if not np.isfinite(error):
        return "open mesh: no volume"
    note = f"volume {100 * error:.2g} % off the rest one"
    if base_error is not None and np.isfinite(base_error):
        note += f" (its base {100 * base_error:.1g} %)"
    return note


def render_multires_comparison(deformer, plain, result, *, size=(1500, 560), up=None, samples: int = 2,
                               direction=None, title: str = "", view=None) -> np.ndarray:
    """(H, W, 3) uint8 picture: rest | plain FFD of the fine mesh | multiresolution.

    Parameters
    ----------
    deformer : MultiresDeformer
    plain : DeformResult
        the same edit as a ``Deformer`` of the fine mesh (``deformer.multires.mesh``)
        with the same lattice.
    result : MultiresResult
        ``deformer.deform(...)`` of the edit.
    size : (width, height) pixels of the whole picture (three panels and captions).
    up : {"x", "y", "z"} or None  upwards in the picture (None: ``guess_up_axis`` of the mesh).
    direction : (3,), optional  viewing direction (default: ``view`` of ``up``).
    view : str or (azimuth, elevation), optional  ``views.parse_view``: "front", "30,20", ...
    title : str  an optional first caption line across the picture.
    """
    from PIL import Image, ImageDraw

    w, h = int(size[0]), int(size[1])
    if w < 90 or h < 60:
        raise InvalidInputError(f"render_multires_comparison: size {size!r} is too small (at least 90x60)")
    mesh = deformer.multires.mesh
    if plain.vertices.shape != mesh.vertices.shape or result.vertices.shape != mesh.vertices.shape:
        raise InvalidInputError("render_multires_comparison: plain and result must deform the decomposition's mesh "
                                f"({mesh.n_vertices} vertices)")
    nums = detail_captions(deformer, plain, result)
    fs = max(9, min(18, h // 30))
    font, _ = _font(fs)
    small, _ = _font(max(8, fs - 3))
    top = (fs + 6) * (1 if title else 0)
    cap = 4 * (fs + 4) + 6
    pw, ph = w // 3, h - top - cap
    if ph < 40:
        raise InvalidInputError(f"render_multires_comparison: size {size!r} leaves no room for the meshes")
    pts = np.concatenate([mesh.vertices, plain.vertices, result.vertices])
    up = guess_up_axis(mesh)[0] if up is None else up
    cam = fit_camera(pts[:: max(1, len(pts) // 200000)], up=up, size=(pw, ph), direction=direction, margin=1.06,
                     view=view)
    panels = [
        (mesh.vertices, [f"rest: {mesh.n_vertices:,} vertices, details |d| up to "
                         f"{np.abs(deformer.multires.displacements).max():.3g}",
                         "fine mesh = smooth base + normal displacements d"]),
        (plain.vertices, _lines("FFD of the fine mesh", nums["plain"],
                                _volume_note(abs(plain.volume - plain.rest_volume) / abs(plain.rest_volume)
                                             if plain.rest_volume else float("nan")))),
        (result.vertices, _lines("multiresolution: base FFD, details along its normals", nums["multires"],
                                 _volume_note(result.volume_error, result.base_volume_error))),
    ]
    pic = Image.new("RGB", (w, h), "white")
    draw = ImageDraw.Draw(pic)
    if title:
        draw.text((6, 3), title, fill=(10, 10, 10), font=font)
    for i, (V, lines) in enumerate(panels):
        img = render(Mesh(V, mesh.faces), camera=cam, size=(pw, ph), samples=samples)
        pic.paste(Image.fromarray(np.ascontiguousarray(img[:, :, :3])), (i * pw, top + cap))
        y = top + 3
        for k, text in enumerate(lines):
            draw.text((i * pw + 6, y), text, fill=(10, 10, 10) if k == 0 else (50, 50, 50),
                      font=font if k == 0 else small)
            y += fs + 4
    return np.asarray(pic)
