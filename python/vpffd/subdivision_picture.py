"""A picture of a displaced subdivision surface edit (``vpffd.SubdivisionMultires``):
four panels with one camera, each captioned with numbers computed from the edit.

1. the rest control mesh (points and edges) over its limit surface S(t_i);
2. the edited control mesh over the deformed limit surface S'(t_i);
3. the detailed result p' = S' + d N_S';
4. the detailed result coloured by the angle between its approximate normals
   (eqs. 6-7) and the area-weighted normals of the deformed mesh.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import _core
from .comparison import AXES, _axis_index, _font, fit_camera, guess_up_axis
from .camera import _size
from .colormap import colormap
from .mesh import Mesh
from .normals import angles_deg
from .picking import _require_embree

InvalidInputError = _core.InvalidInputError
BackendUnavailableError = _core.BackendUnavailableError


def control_edges(faces) -> np.ndarray:
    """(m, 2) int32 undirected edges, each once, of polygon faces (n, k) (k = 3 or 4:
    the control mesh of a SubdivisionMultires)."""
    F = np.asarray(faces)
    E = np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2)
    return np.unique(np.sort(E, axis=1), axis=0).astype(np.int32)


def normal_error_deg(result, faces) -> np.ndarray:
    """(V,) degrees between a frame's approximate normals ``result.normals`` and the
    area-weighted vertex normals of ``result.vertices`` joined by ``faces``."""
    return angles_deg(result.normals, _core.vertex_normals(result.vertices, np.asarray(faces, dtype=np.int32)))


@dataclass(frozen=True)
class EditNumbers:
    """What the captions say, computed from one edit (``edit_numbers``).

    control_points : int; moved : int (control points that differ from the rest ones);
    rms_initial, rms_final : float (fit RMS |p - S|, world units); limit_shift : float
    (largest |S' - S| over the fine vertices); volume_change : float (relative, NaN
    when open); base_volume_error : float (relative error of the base points' volume;
    NaN when open); preserved : bool; normal_mean, normal_max : float (degrees).
    """
    control_points: int
    moved: int
    rms_initial: float
    rms_final: float
    limit_shift: float
    volume_change: float
    base_volume_error: float
    preserved: bool
    normal_mean: float
    normal_max: float


def edit_numbers(sm, result, angles=None) -> EditNumbers:
    """The numbers of the captions for ``result = sm.deform(...)`` (``angles``: the
    (V,) normal errors when already computed)."""
    a = normal_error_deg(result, sm.mesh.faces) if angles is None else np.asarray(angles)
    moved = int(np.any(np.asarray(result.control_points) != sm.control_points, axis=1).sum())
    shift = float(np.linalg.norm(result.base_vertices - sm.limit_points, axis=1).max())
    return EditNumbers(sm.n_control, moved, sm.rms_initial, sm.rms_final, shift, result.volume_error,
                       result.base_volume_error, result.volume_mode == "base", float(np.nanmean(a)),
                       float(np.nanmax(a)))


def edit_captions(n: EditNumbers, top: float) -> list:
    """(title, numbers) per panel; ``top`` is the colour scale's end in degrees."""
    if math.isfinite(n.volume_change):
        vol = f"volume {100 * n.volume_change:+.2f} %"
        if n.preserved:
            vol += f", base kept (error {n.base_volume_error:+.0e})"
    else:
        vol = "open mesh: no volume"
    return [("control mesh + limit surface", f"{n.control_points} control points, fit RMS {n.rms_initial:.3g} "
             f"-> {n.rms_final:.3g}"),
            ("edited", f"{n.moved} control points moved{' (with the volume correction)' * n.preserved}, "
             f"limit surface up to {n.limit_shift:.3g}"),
            ("detailed result", vol),
            ("approximate normal error", f"mean {n.normal_mean:.2f} deg, max {n.normal_max:.2f} "
             f"(colour 0-{top:.2g})")]


def render_subdivision_edit(sm, result, *, size=(1600, 480), up=None, samples: int = 2, angles=None,
                            top=None, captions=None, view=None) -> np.ndarray:
    """The four panels of an edit (see the module), one camera, captions above.

    Parameters
    ----------
    sm : SubdivisionMultires
    result : MultiresResult
        ``sm.deform(...)`` (or an affine group's frame).
    size : (width, height)
        the whole picture, pixels.
    up : "x", "y", "z" or None
        upwards in the picture (None: ``comparison.guess_up_axis`` of the mesh).
    angles : (V,) float, optional
        the normal errors in degrees (default ``normal_error_deg``).
    top : float, optional
        degrees at which the colour saturates (default: the largest error, at
        least 1).
    captions : list of 4 (title, numbers), optional
        default ``edit_captions(edit_numbers(sm, result), top)``.
    view : str or (azimuth, elevation), optional
        the camera (``views.parse_view``: "front", "30,20", ...; default the
        three-quarter view).

    Returns
    -------
    (H, W, 3) uint8 image (captions only when they take at most a third of the
    height). Needs Embree (``vpffd.render``) and Pillow.
    """
    _require_embree("render_subdivision_edit")
    try:
        from PIL import Image, ImageDraw
    except ImportError:
        raise BackendUnavailableError("render_subdivision_edit: captions need Pillow (pip install pillow)") from None
    from .rendering import render
    w, h = _size(size, "render_subdivision_edit")
    F = sm.mesh.faces
    if result.vertices.shape != sm.mesh.vertices.shape:
        raise InvalidInputError(f"render_subdivision_edit: the result has {len(result.vertices)} vertices, the "
                                f"mesh {sm.n_vertices}")
    a = normal_error_deg(result, F) if angles is None else np.asarray(angles, dtype=np.float64)
    top = max(1.0, float(np.nanmax(a))) if top is None else float(top)
    if captions is None:
        captions = edit_captions(edit_numbers(sm, result, a), top)
    if len(captions) != 4:
        raise InvalidInputError(f"render_subdivision_edit: expected 4 captions, got {len(captions)}")
    up = guess_up_axis(sm.mesh)[0] if up is None else AXES[_axis_index(up)]
    edges = control_edges(sm.control_faces)
    net_kw = dict(point_radius=2.2, line_alpha=0.8, hidden_alpha=0.2, line_width=1.0)
    grey = np.full((sm.n_vertices, 3), 0.78)
    panels = [(Mesh(sm.limit_points, F), (sm.control_points, edges), grey),
              (Mesh(result.base_vertices, F), (result.control_points, edges), grey),
              (Mesh(result.vertices, F), None, grey),
              (Mesh(result.vertices, F), None, colormap(np.nan_to_num(a), "viridis", 0.0, top))]
    n = len(panels)
    fs = max(10, int(round(0.03 * min(h, 1.2 * w / n))))
    cap_h = int(2.7 * fs)
    if h < 3 * cap_h:  # a thumbnail: the panels alone (captions would cover most of it)
        cap_h = 0
    pw, ph = w // n, h - cap_h
    if pw < 8 or ph < 8:
        raise InvalidInputError(f"render_subdivision_edit: {w} x {h} pixels is too small for {n} panels")
    pts = np.concatenate([sm.limit_points, result.vertices, sm.control_points, result.control_points])
    cam = fit_camera(pts, up=up, size=(pw, ph), view=view)
    canvas = np.full((h, w, 3), 255, np.uint8)
    x0 = (w - n * pw) // 2
    for i, (m, net, colors) in enumerate(panels):
        img = render(m, cam, size=(pw, ph), colors=colors, samples=samples, net=net, **(net_kw if net else {}))
        canvas[cap_h:, x0 + i * pw:x0 + (i + 1) * pw] = img
    pic = Image.fromarray(canvas)
    draw = ImageDraw.Draw(pic)
    font, _ = _font(fs)
    small, _ = _font(max(9, int(round(0.8 * fs))))
    for i, (title, numbers) in enumerate(captions if cap_h else ()):
        cx = x0 + i * pw + pw // 2
        draw.text((cx, int(0.25 * fs)), str(title), fill=(25, 25, 25), font=font, anchor="ma")
        draw.text((cx, int(1.45 * fs)), str(numbers), fill=(95, 95, 95), font=small, anchor="ma")
    return np.asarray(pic, dtype=np.uint8).copy()
