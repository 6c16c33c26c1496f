"""Pictures that explain a deformation: rest | plain FFD | volume-preserved side
by side, one camera, each panel captioned with its volume, the surface coloured
by the local volume change det J of the deformation, and the model's own up axis.

>>> import vpffd
>>> mesh = vpffd.shapes.icosphere(3)
>>> lat = vpffd.Lattice.around(mesh, shape=(5, 5, 5))
>>> d = vpffd.Deformer(mesh, lat)
>>> r = d.deform(vpffd.edits.squash(lat.control_points, 0.6), axes="xy")
>>> img = vpffd.render_comparison(d, r, size=(480, 200))  # doctest: +SKIP
"""
from __future__ import annotations

import math

import numpy as np

from . import _arrays, _core
from .camera import Camera, _size
from .colormap import FOLD_COLOR, colormap, volume_change_colors, volume_change_limit
from .mesh import Mesh
from .picking import Scene, _require_embree

InvalidInputError = _core.InvalidInputError
BackendUnavailableError = _core.BackendUnavailableError

LATTICE_STYLES = ("none", "faint", "full")

from .views import AXES, _axis_index, guess_up_axis, model_frame, parse_view, view_direction  # noqa: F401


def fit_camera(points, up="z", size=(800, 600), direction=None, fov: float = 30.0, margin: float = 1.04,
               view=None) -> Camera:
    """A camera looking along ``direction`` (default: ``view_direction(up, view)``,
    ``view`` as ``views.parse_view`` takes it: "front", "30,20", ...) with
    ``up`` upwards, placed so that every one of ``points`` (n, 3) lies in the
    image of ``size`` with ``margin`` (>= 1) and their projection is centred: the
    points' extent fills the limiting image dimension (unlike
    ``Camera.framing``, which fits the bounding sphere)."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if P.shape[0] == 0 or not np.isfinite(P).all():
        raise InvalidInputError("fit_camera: no finite points to frame")
    w, h = _size(size, "fit_camera")
    k = _axis_index(up)
    up_v = np.zeros(3)
    up_v[k] = 1.0
    d = view_direction(up, view) if direction is None else np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    f = -d
    if np.linalg.norm(np.cross(f, up_v)) < 1e-6:
        # Straight down (or up): the image's up is the model's back (front), so the
        # front of the model is at the bottom of a top view.
        up_v = -np.sign(d @ up_v) * model_frame(up)[0]
    r = np.cross(f, up_v)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    ty = math.tan(math.radians(fov) / 2)
    tx = ty * w / h
    # Column by column: on millions of points numpy's reductions along axis 0
    # and its (n, 3) @ (3, 3) product are 5-30 times slower than on columns.
    x, y, z = (np.ascontiguousarray(P[:, k]) for k in range(3))
    lo, hi = np.array([x.min(), y.min(), z.min()]), np.array([x.max(), y.max(), z.max()])
    c = 0.5 * (lo + hi)
    size_ = float(np.linalg.norm(hi - lo)) or 1.0
    # Coordinates along r, u, d relative to c.

    def along(e):
        a = x * e[0]
        a += y * e[1]
        a += z * e[2]
        a -= float(e @ c)
        return a

    A, B, Z = along(r), along(u), along(d)
    # The target moves by (sa, sb) along (r, u); the distance that fits every point,
    # max(Z + margin |A - sa| / tx) (and the same for B), follows from four maxima
    # taken once, since |a - s| = max(a - s, s - a).
    ext_a = (np.max(Z + (margin / tx) * A), np.max(Z - (margin / tx) * A))
    ext_b = (np.max(Z + (margin / ty) * B), np.max(Z - (margin / ty) * B))
    sa = sb = dist = 0.0
    for _ in range(4):  # distance for the target, then centre the projection, and again
        dist = max(ext_a[0] - margin * sa / tx, ext_a[1] + margin * sa / tx,
                   ext_b[0] - margin * sb / ty, ext_b[1] + margin * sb / ty)
        dist = max(float(dist), 1e-6 * size_)
        inv_depth = 1.0 / (dist - Z)
        sx, sy = (A - sa) * inv_depth, (B - sb) * inv_depth
        mx, my = 0.5 * (sx.min() + sx.max()), 0.5 * (sy.min() + sy.max())
        sa, sb = sa + mx * dist, sb + my * dist
    c = c + sa * r + sb * u
    return Camera(c + dist * d, c, up_v, fov)


def local_volume_change(deformer, control_points=None) -> np.ndarray:
    """(V,) det J at every vertex: the local volume ratio of the FFD with
    ``control_points`` (default: the lattice's), exact from the B-spline
    Jacobians. Below 1 compressed, above 1 expanded, <= 0 folded."""
    return deformer.jacobian_determinants(control_points)


def _axes_of(result) -> str:
    axes = []
    for s in getattr(result, "steps", None) or []:
        a = s.get("axis") if isinstance(s, dict) else None
        a = AXES[a] if isinstance(a, (int, np.integer)) and 0 <= a < 3 else a
        if isinstance(a, str) and a in AXES and a not in axes:
            axes.append(a)
    return "".join(sorted(axes))


def _font(px: int):
    from PIL import ImageFont
    for name in ("DejaVuSans.ttf", "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf"):
        try:
            return ImageFont.truetype(name, px), True
        except OSError:
            pass
    try:
        import matplotlib
        import os
        return ImageFont.truetype(os.path.join(matplotlib.get_data_path(), "fonts", "ttf", "DejaVuSans.ttf"),
                                  px), True
    except (ImportError, OSError):
        pass
    try:
        return ImageFont.load_default(size=px), False
    except TypeError:  # Pillow < 10.1
        return ImageFont.load_default(), False


def _lattice_kw(style: str) -> dict:
    if style == "faint":
        return dict(points=False, line_color=(0.30, 0.36, 0.50), line_alpha=0.30, hidden_alpha=0.35,
                    line_width=1.0)
    return dict(point_radius=2.2, line_alpha=0.9, hidden_alpha=0.25, line_width=1.2)


def _pct(x: float) -> str:
    return f"{100 * x:+.2f} %"


def render_comparison(mesh, result, lattice=None, *, size=(1600, 600), up=None, lattice_style: str = "faint",
                      color: str = "volume", samples: int = 2, labels=None, limit=None, fov: float = 30.0,
                      background=(1.0, 1.0, 1.0), view=None, folds: bool = True) -> np.ndarray:
    """Panels side by side, one camera: rest | plain FFD | volume-preserved.

    One camera and one framing for all panels: fitted to every panel's mesh, its
    drawn lattice and the dragged points. A frame with point constraints (a drag)
    shows the dragged points (dark dots) and their targets (red rings), joined by a
    line while they are apart; its plain FFD panel is the drag without the volume
    correction (the same control points and constraints, ``preserve_volume=False``).

    Parameters
    ----------
    mesh : vpffd.Deformer, or the rest Mesh (then ``lattice`` is needed)
        the deformer that produced ``result`` (it gives the plain FFD and the
        Jacobians; a Mesh and a Lattice build one).
    result : DeformResult, or a list of them / of (label, DeformResult) pairs
        corrected frames of the same edit (e.g. axes "xy" and "z"), one panel
        each; the plain FFD panel uses the first one's uncorrected control
        points (``control_points - offsets``).
    lattice : vpffd.Lattice, optional
        with a Mesh for ``mesh``.
    size : (width, height)
        the whole picture, in pixels.
    up : "x", "y", "z" or None
        the model's up axis, upwards in the picture (None: ``guess_up_axis``).
    lattice_style : "none", "faint" or "full"
        no lattice; thin translucent lines; lines and control points.
    color : "volume" or "none"
        colour the surface by the local volume change det J (log scale centred
        at 1: blue compressed, red expanded, green folds) with a colour bar, or
        plain grey.
    samples : int
        anti-aliasing rays per pixel per axis at edges (1..8).
    labels : list of str, optional
        panel titles (default "rest", "plain FFD", "volume-preserved, <axes>").
    limit : float, optional
        det J at which the colours saturate (and 1 / limit); default: covers
        95 % of the values shown.
    view : str or (azimuth, elevation), optional
        the camera's side of the model (``views.parse_view``: "front", "back",
        "left", "right", "top", "bottom", or degrees such as "30,20"); default a
        three-quarter view from the front, right and above.
    folds : bool
        caption every deformed panel with its fold verdict
        (``FoldReport.verdict(short=True)`` of ``Deformer.check_folds``).

    Returns
    -------
    (H, W, 3) uint8 image. Captions need Pillow (``pip install pillow``).
    """
    _require_embree("render_comparison")
    try:
        from PIL import Image, ImageDraw
    except ImportError:
        raise BackendUnavailableError("render_comparison: captions need Pillow (pip install pillow)") from None
    from .deformer import Deformer, DeformResult
    from .rendering import _color3, render

    if isinstance(mesh, Deformer):
        d = mesh
    else:
        if lattice is None:
            raise InvalidInputError("render_comparison: pass the Deformer, or the rest mesh and its lattice")
        d = Deformer(mesh, lattice)
    rest, lat = d.mesh, d.lattice
    if lattice_style not in LATTICE_STYLES:
        raise InvalidInputError(f"render_comparison: lattice_style must be one of {', '.join(LATTICE_STYLES)}, "
                                f"got {lattice_style!r}")
    if color not in ("volume", "none"):
        raise InvalidInputError(f"render_comparison: color must be 'volume' or 'none', got {color!r}")
    items = result if isinstance(result, (list, tuple)) else [result]
    pairs = []
    for it in items:
        lab, r = it if isinstance(it, tuple) else (None, it)
        if not isinstance(r, DeformResult):
            raise TypeError(f"render_comparison: expected DeformResult(s), got {type(r).__name__}")
        if r.vertices.shape != rest.vertices.shape:
            raise InvalidInputError(f"render_comparison: a result has {r.vertices.shape[0]} vertices, the mesh "
                                    f"{rest.n_vertices}")
        pairs.append((lab, r))
    if not pairs:
        raise InvalidInputError("render_comparison: no result to show")
    w, h = _size(size, "render_comparison")
    up = guess_up_axis(rest)[0] if up is None else AXES[_axis_index(up)]
    bg = _color3(background, "background")

    r0 = pairs[0][1]
    plain_cp = r0.control_points - r0.offsets
    preserved = any(r.steps for _, r in pairs)
    cons = r0.constraints
    plain_X, plain_vol = None, r0.volume_before
    if cons is not None and preserved:
        # The drag without the correction: the same control points and constraints.
        from ._core import SolverError
        try:
            t = d.deform(plain_cp, preserve_volume=False, axes=_axes_of(r0) or "xyz", constraints=cons)
            plain_cp, plain_X, plain_vol = t.control_points, t.vertices, t.volume
        except (SolverError, InvalidInputError):
            pass
    elif not preserved:
        plain_cp, plain_X, plain_vol = r0.control_points, r0.vertices, r0.volume
    if plain_X is None:
        plain_X = d.ffd(plain_cp)
    panels = [("rest", rest.vertices, lat.rest_points, None, r0.rest_volume)]
    panels.append(("plain FFD" if preserved else "deformed", plain_X, plain_cp, plain_cp, plain_vol))
    if preserved:
        for lab, r in pairs:
            axes = _axes_of(r)
            panels.append((lab or (f"volume-preserved, {axes}" if axes else "volume-preserved"), r.vertices,
                           r.control_points, r.control_points, r.volume))
    if labels is not None:
        if len(labels) != len(panels):
            raise InvalidInputError(f"render_comparison: {len(labels)} labels for {len(panels)} panels")
        panels = [(str(lb),) + p[1:] for lb, p in zip(labels, panels)]
    n = len(panels)

    # Layout: captions above, colour bar below, panels of one size between.
    fs = max(10, int(round(0.03 * min(h, 1.2 * w / n))))
    font, unicode_ok = _font(fs)
    small, _ = _font(max(9, int(round(0.85 * fs))))
    cap_h = int((3.9 if folds else 2.7) * fs)
    bar_h = int(3.0 * fs) if color == "volume" else 0
    pw, ph = w // n, h - cap_h - bar_h
    if pw < 8 or ph < 8:
        raise InvalidInputError(f"render_comparison: {w} x {h} pixels is too small for {n} panels")

    detj = [None] * n
    if color == "volume":
        detj[0] = np.ones(rest.n_vertices)
        for i in range(1, n):
            detj[i] = local_volume_change(d, panels[i][3])
        if limit is None:
            limit = volume_change_limit(np.concatenate(detj[1:]))
        limit = float(limit)
        if not (math.isfinite(limit) and limit > 1):
            raise InvalidInputError(f"render_comparison: limit must be a finite number > 1, got {limit!r}")

    # One framing for every panel: meshes, the lattices drawn, handles and targets.
    framed = [p[1] for p in panels]
    if lattice_style != "none":
        framed += [np.asarray(lat.expanded_control_points(p[2]) if lat.periodic else p[2]).reshape(-1, 3)
                   for p in panels]
    handles = None
    if cons is not None:
        S, T = cons
        handles = [S] + [lat.deform_points(S, p[2], outside="extrapolate") for p in panels[1:]]
        framed += handles + [T]
    # The margin leaves room for the lattice's points and lines drawn at the extremes.
    margin = 1.04 + (8.0 / min(pw, ph) if lattice_style != "none" else 0.0)
    cam = fit_camera(np.concatenate(framed), up=up, size=(pw, ph), fov=fov, view=view, margin=margin)
    canvas = np.empty((h, w, 3), np.uint8)
    canvas[:] = np.round(bg * 255).astype(np.uint8)
    x0 = (w - n * pw) // 2
    # The panels share the faces: one BVH, built for the rest mesh and refitted
    # to each deformed one. Measured (1.3 M triangles, 2 threads): the build and
    # two refits take about the wall time of three quick (low quality) builds,
    # ~1.2 times their CPU time, and rays on the better BVH ~5 % less; each
    # further panel costs a refit, ~1/4 of a quick build.
    scene = Scene(rest, refit=True)
    for i, (lab, V, cp, _, vol) in enumerate(panels):
        if i > 0:
            scene.set_vertices(V)
        kw = {} if lattice_style == "none" else dict(lattice=lat, control_points=cp, **_lattice_kw(lattice_style))
        colors = volume_change_colors(detj[i], limit) if color == "volume" else None
        img = render(scene, cam, size=(pw, ph), colors=colors, samples=samples, background=bg, **kw)
        canvas[cap_h:cap_h + ph, x0 + i * pw:x0 + (i + 1) * pw] = img

    pic = Image.fromarray(canvas)
    draw = ImageDraw.Draw(pic)
    if handles is not None:
        for i in range(n):
            _draw_drag(draw, cam, (pw, ph), (x0 + i * pw, cap_h), handles[i], cons[1], fs)
    ink, grey = (25, 25, 25), (95, 95, 95)
    minus = "\u2212" if unicode_ok else "-"
    rest_vol = r0.rest_volume
    for i, (lab, V, cp, _, vol) in enumerate(panels):
        cx = x0 + i * pw + pw // 2
        draw.text((cx, int(0.25 * fs)), lab, fill=ink, font=font, anchor="ma")
        if vol is None or not (math.isfinite(vol) and math.isfinite(rest_vol)) or rest_vol == 0:
            sub = "no enclosed volume (open mesh)"
        elif i == 0:
            sub = f"volume {vol:.6g}"
        else:
            ch = (vol - rest_vol) / rest_vol
            sub = (f"volume {vol:.6g}  ({_pct(ch)})" if abs(ch) >= 5e-5 else
                   f"volume {vol:.6g}  (error {ch:+.1e})")
        draw.text((cx, int(1.45 * fs)), sub.replace("-", minus), fill=grey, font=small, anchor="ma")
        if folds and i > 0:
            verdict = d.check_folds(cp).verdict(short=True)
            folded = verdict.startswith("FOLDS")
            draw.text((cx, int(2.6 * fs)), "lattice " + verdict if not folded else verdict,
                      fill=(190, 30, 30) if folded else grey, font=small, anchor="ma")
    if color == "volume":
        _colour_bar(draw, pic, w, h - bar_h, bar_h, fs, font, small, limit,
                    int(sum(int((dj <= 0).sum()) for dj in detj[1:])), unicode_ok)
    return np.asarray(pic, dtype=np.uint8).copy()


def _draw_drag(draw, cam, size, origin, handles, targets, fs):
    """Dragged points (dark dots) and their targets (red rings) over one panel, joined
    by a line while they are apart; ``origin`` is the panel's top left pixel."""
    a = cam.project(handles, size) + origin
    b = cam.project(targets, size) + origin
    r = max(3, int(round(0.28 * fs)))
    for (ax, ay), (bx, by) in zip(a, b):
        if not np.isfinite([ax, ay, bx, by]).all():
            continue
        if math.hypot(bx - ax, by - ay) > r:
            draw.line([ax, ay, bx, by], fill=(200, 40, 40), width=max(1, r // 2))
        draw.ellipse([bx - r - 1, by - r - 1, bx + r + 1, by + r + 1], outline=(200, 40, 40), width=max(2, r // 2))
        draw.ellipse([ax - r + 1, ay - r + 1, ax + r - 1, ay + r - 1], fill=(20, 20, 60))


def _colour_bar(draw, pic, w, top, height, fs, font, small, limit, folds, unicode_ok):
    """The det J scale: a log-scale gradient 1/limit .. limit with ticks, and the fold swatch."""
    from PIL import Image
    le = "\u2264" if unicode_ok else "<="
    left, right = "det J:  compressed", "expanded"
    fold_label = f"fold (det J {le} 0)" + (f": {folds:,} vertices" if folds else ": at no vertex")
    gap = int(0.6 * fs)
    bh = max(6, int(0.7 * fs))
    lw, rw, fw = (int(draw.textlength(t, font=small)) for t in (left, right, fold_label))
    side = max(lw, rw + 2 * gap + bh + int(0.4 * fs) + fw)  # keep the bar centred
    bw = int(min(0.42 * w, 40 * fs, w - 2 * (side + gap) - 2 * gap))
    if bw < 4 * fs:  # too narrow for a readable scale: the bar alone, full width
        bw, side = max(8, w - 4 * gap), None
    bx = (w - bw) // 2
    by = top + int(0.35 * fs)
    t = np.linspace(-1.0, 1.0, bw)
    row = (colormap(t, "coolwarm", -1.0, 1.0) * 255 + 0.5).astype(np.uint8)
    pic.paste(Image.fromarray(np.repeat(row[None], bh, axis=0)), (bx, by))
    draw.rectangle([bx - 1, by - 1, bx + bw, by + bh], outline=(90, 90, 90))
    ticks = [1 / limit, 1 / math.sqrt(limit), 1.0, math.sqrt(limit), limit]
    for k, v in enumerate(ticks):
        x = bx + int(round((math.log(v) / math.log(limit) + 1) / 2 * (bw - 1)))
        draw.line([x, by + bh, x, by + bh + int(0.3 * fs)], fill=(90, 90, 90))
        txt = f"{v:.3g}"
        if k == 0:
            txt = le + " " + txt
        elif k == len(ticks) - 1:
            txt = ("\u2265 " if unicode_ok else ">= ") + txt
        draw.text((x, by + bh + int(0.35 * fs)), txt, fill=(60, 60, 60), font=small, anchor="ma")
    if side is None:
        return
    ink = (40, 40, 40)
    draw.text((bx - gap, by + bh // 2), left, fill=ink, font=small, anchor="rm")
    draw.text((bx + bw + gap, by + bh // 2), right, fill=ink, font=small, anchor="lm")
    sx = bx + bw + gap + rw + 2 * gap
    fold = tuple(int(round(255 * c)) for c in FOLD_COLOR)
    draw.rectangle([sx, by, sx + bh, by + bh], fill=fold, outline=(90, 90, 90))
    draw.text((sx + bh + int(0.4 * fs), by + bh // 2), fold_label, fill=ink, font=small, anchor="lm")
