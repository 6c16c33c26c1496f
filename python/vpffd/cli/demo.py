"""The README's main job: the paper's two animations (Hahmann et al. 2012,
Figures 1 and 6) on built-in meshes, plain FFD against the volume-preserving
one with the correction restricted to chosen axes.

Writes, under ``out``:

- ``<scene>/frame_NNN.png``: every frame, the variants side by side;
- ``<scene>.gif``: the same frames as an animated GIF;
- ``<scene>_keyframes.png``: the paper's layout, one row per variant;
- ``volume.png``: volume over time (matplotlib), and ``volume.csv``;
- the moving-object scenes (``vpffd.cli.motion``), the multiresolution scene
  (``vpffd.cli.multires_scene``) and the displaced subdivision surface scene
  (``vpffd.cli.subdiv_scene``): their GIFs, frames and CSV files, and
  ``multires_details.png`` (a bumpy ball squashed: FFD of the fine mesh against the
  multiresolution edit, with the measured change of the details);

and prints the volume change of every frame.
"""
from __future__ import annotations

import csv
import importlib.util
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import shapes
from .._files import open_replacing, replaced_path
from ..animate import BouncingBall, Twist, run_animation
from ..deformer import Deformer
from ..lattice import Lattice
from ..mesh import Mesh
from .frames import bar, frame_dir, label as _label, save_frame, write_gif

# (key, label, preserve, axes); the paper's Figure 6 rows are plain, xy and z.
VARIANTS = (
    ("plain", "plain FFD", False, ""),
    ("xy", "preserved, xy only", True, "xy"),
    ("z", "preserved, z only", True, "z"),
    ("xyz", "preserved, xyz", True, "xyz"),
)

_LABELS = {v[0]: v[1] for v in VARIANTS}
# Caption lines of a panel: the variant, its volume, its fold check; the frame's
# number goes on the line after them.
CAPTION_LINES = 3

# The twist at which the plain FFD of box(32) in a 5x5x5 cubic lattice (2 %
# padding) loses 65.7 % of its volume, the paper's "66 % at the last frame".
CUBE_TWIST_DEG = 345.0
# Deepest flattening of the ball (in ball heights) and drop height: with 41
# frames the plain FFD then loses 29.7 %, 50.1 % and 63.6 % at frames 12, 14
# and 16 (paper: 28, 51, 64 % at its frames 25, 30, 35).
BALL_SQUASH = 0.7
BALL_DROP = 0.5
BALL_FRAMES = 41
BALL_KEYFRAMES = (0, 12, 14, 16)


@dataclass
class Scene:
    """One animated example: a mesh, its lattice, an animator, the frames."""
    key: str
    title: str
    mesh: Mesh
    lattice: Lattice
    animator: object
    frames: int
    keyframes: list
    paper: str
    param: object  # frame -> the animation parameter shown in the table
    param_name: str
    view: tuple
    overlay: dict  # render() arguments for the lattice drawn over the mesh
    results: dict = field(default_factory=dict)
    fold_marks: dict = field(default_factory=dict)  # (variant, frame) -> "ok" / "FOLD" / "?"


def twisting_cube(quick: bool = False) -> Scene:
    """The paper's Figure 6: box(32) (6,146 vertices) twisted to 345 degrees."""
    cube = shapes.box(12 if quick else 32)
    lat = Lattice.around(cube, shape=(5, 5, 5), degree=3, padding=0.02)
    frames = 9 if quick else 25
    anim = Twist(lat, angle=CUBE_TWIST_DEG, axis="z", duration=2.0)
    key = [0, frames // 3, (2 * frames) // 3, frames - 1]
    return Scene("twisting_cube", f"Twisting cube: box({12 if quick else 32}), {cube.n_vertices:,} vertices, "
                 f"lattice 5x5x5 cubic, twist 0 to {CUBE_TWIST_DEG:g} deg",
                 cube, lat, anim, frames, key,
                 "paper, Figure 6 (6,146 vertices): 66 % of the volume lost at the last frame without preservation",
                 lambda t: CUBE_TWIST_DEG * t / anim.duration, "twist deg", (1.0, -1.6, 0.9),
                 dict(points=False, line_color=(0.30, 0.36, 0.50), line_alpha=0.30, hidden_alpha=0.35))  # the lattice drawn as render_comparison's "faint"


def bouncing_ball(quick: bool = False) -> Scene:
    """The paper's Figure 1 on an icosphere: dropped, flattened on the ground, bounced back."""
    ball = shapes.icosphere(3 if quick else 4)
    lat = Lattice.around(ball, shape=(8, 8, 8), degree=3, padding=0.05)
    anim = BouncingBall(lat, bottom=float(ball.bounds[0, 2]), squash=BALL_SQUASH, drop=BALL_DROP)
    frames = 21 if quick else BALL_FRAMES
    # The paper's frames 25, 30, 35 of its animation; here the same moments of
    # the flattening, found by time for other frame counts.
    ref = np.array(BALL_KEYFRAMES) / (BALL_FRAMES - 1) * anim.duration
    times = anim.times(frames)
    key = [int(np.argmin(np.abs(times - r))) for r in ref]
    return Scene("bouncing_ball", f"Bouncing ball: icosphere({3 if quick else 4}), {ball.n_vertices:,} vertices, "
                 f"lattice 8x8x8 cubic, dropped from half its height, flattened to {100 * (1 - BALL_SQUASH):.0f} %",
                 ball, lat, anim, frames, key,
                 "paper, Figure 1 (RedBox, 710,322 vertices): 28 %, 51 %, 64 % lost at its frames 25, 30, 35",
                 lambda t: 100 * anim.flattening(t), "flatten %", (1.0, -2.2, 0.45),
                 dict(points=False, line_color=(0.30, 0.36, 0.50), line_alpha=0.30, hidden_alpha=0.35))


# --- rendering -------------------------------------------------------------------
def _renderer():
    """vpffd.render and Camera, or None when this build has no renderer."""
    from .. import _core
    from ..camera import Camera
    from ..rendering import render
    return (render, Camera) if _core.has_embree else None


def _bounds(scene: Scene) -> np.ndarray:
    lo = np.full(3, np.inf)
    hi = -lo
    for r in scene.results.values():
        lo = np.minimum(lo, r.vertices.min(axis=(0, 1)))
        hi = np.maximum(hi, r.vertices.max(axis=(0, 1)))
    return np.stack([lo, hi])


def _render_scene(scene: Scene, out: Path, size, progress=None, fps=None) -> list:
    """Renders every frame of every variant; writes the frame PNGs, the GIF and
    the key-frame sheet. Returns the written paths."""
    from PIL import Image, ImageDraw
    render, Camera = _renderer()
    from ..comparison import _colour_bar, _font, fit_camera, local_volume_change
    from ..colormap import volume_change_colors, volume_change_limit
    w, h = size
    keys = list(scene.results)
    # The same camera for every frame and variant, fitted to all of them (the
    # meshes fill the panel), and the surface coloured by the local volume
    # change det J on one scale for the whole animation, as render_comparison.
    pts = np.concatenate([scene.results[k].vertices[f] for k in keys for f in range(scene.frames)])
    cam = fit_camera(np.concatenate([pts, _bounds(scene)]), up="z", size=(w, h), direction=scene.view)
    d = Deformer(scene.mesh, scene.lattice)
    detj = {k: [local_volume_change(d, scene.results[k].corrected_points[f]) for f in range(scene.frames)]
            for k in keys}
    limit = volume_change_limit(np.concatenate([x for k in keys for x in detj[k]]))
    faces = scene.mesh.faces
    fdir = frame_dir(out, scene.key, scene.frames)
    written, sheet_cells, gif = [], {}, []
    total = scene.frames * len(keys)
    for f in range(scene.frames):
        panels = []
        for k in keys:
            r = scene.results[k]
            img = render(Mesh(r.vertices[f], faces), camera=cam, lattice=scene.lattice, size=(w, h),
                         control_points=r.corrected_points[f], colors=volume_change_colors(detj[k][f], limit),
                         samples=2, **scene.overlay)
            if r.preserve:
                vol = f"volume kept (error {r.volume_change[f]:+.0e})"
            else:
                vol = f"volume {100 * r.volume_change_plain[f]:+.1f} %"
            mark = _fold_mark(scene, k, f)
            fold_note = {"FOLD": "lattice FOLDS here", "?": "fold check undecided"}.get(mark, "")
            pic = _label(Image.fromarray(np.ascontiguousarray(img)), [_LABELS[k], vol, fold_note])
            if mark == "FOLD":  # a folded frame is framed in red, so it shows in the GIF at a glance
                ImageDraw.Draw(pic).rectangle([0, 0, pic.width - 1, pic.height - 1], outline=(200, 30, 30),
                                              width=max(3, w // 160))
            panels.append(pic)
            if f in scene.keyframes:
                sheet_cells[(k, f)] = pic
            if progress:
                progress(f * len(keys) + keys.index(k) + 1, total)
        row = Image.new("RGB", (w * len(panels), h), "white")
        for i, p in enumerate(panels):
            row.paste(p, (i * w, 0))
        # Below the panels' three caption lines (name, volume, fold check).
        _label(row, [f"frame {f}  t = {scene.results[keys[0]].times[f]:.2f} s"], first=CAPTION_LINES)
        written.append(save_frame(fdir, f, row))
        gif.append(row)
    step = scene.animator.duration / max(scene.frames - 1, 1) if fps is None else 1.0 / fps
    written.append(write_gif(gif, out / f"{scene.key}.gif", step))
    fs = max(10, int(round(0.045 * h)))
    bar_h = int(3.0 * fs)
    sheet = Image.new("RGB", (w * len(scene.keyframes), h * len(keys) + bar_h), "white")
    for i, k in enumerate(keys):
        for j, f in enumerate(scene.keyframes):
            cell = sheet_cells[(k, f)].copy()
            _label(cell, [f"frame {f}"], first=CAPTION_LINES)
            sheet.paste(cell, (j * w, i * h))
    from PIL import ImageDraw
    font, unicode_ok = _font(fs)
    small, _ = _font(max(9, int(round(0.85 * fs))))
    folds = sum(int((x <= 0).sum()) for k in keys for f, x in enumerate(detj[k]) if f in scene.keyframes)
    _colour_bar(ImageDraw.Draw(sheet), sheet, sheet.width, h * len(keys), bar_h, fs, font, small, limit, folds,
                unicode_ok)
    sheet_path = out / f"{scene.key}_keyframes.png"
    with replaced_path(sheet_path, "demo") as tmp:
        sheet.save(tmp)
    written.append(sheet_path)
    return written


# --- numbers ---------------------------------------------------------------------
def _fold_mark(scene: Scene, key: str, f: int) -> str:
    """One word for a frame's fold check: "ok" (proven fold-free), "FOLD", or "?"
    (undecided). Checked once per variant and frame: the table and the pictures share it."""
    if (key, f) not in scene.fold_marks:
        from ..folds import check_folds
        rep = check_folds(scene.lattice, scene.results[key].corrected_points[f])
        scene.fold_marks[(key, f)] = "FOLD" if rep.folded else ("ok" if rep.certified else "?")
    return scene.fold_marks[(key, f)]


def _table(scene: Scene, stream) -> None:
    res = scene.results
    plain = res["plain"]
    kept = [k for k in res if res[k].preserve]
    p = lambda s: print(s, file=stream)  # noqa: E731
    p("")
    p(scene.title)
    p(f"  volume change against the rest volume {plain.rest_volume:.6g}; plain FFD in %, preserved frames "
      f"as relative error")
    head = f"  {'frame':>5} {'t (s)':>6} {scene.param_name:>10} {'plain FFD':>10}"
    for k in kept:
        head += f" {'keep ' + res[k].axes:>10}"
    p(head + "  folds (plain, " + ", ".join(res[k].axes for k in kept) + ")")
    for f, t in enumerate(plain.times):
        line = f"  {f:>5} {t:6.3f} {scene.param(t):10.1f} {100 * plain.volume_change_plain[f]:+9.2f}%"
        for k in kept:
            line += f" {res[k].volume_change[f]:+10.1e}"
        line += "  " + " ".join(_fold_mark(scene, k, f) for k in ["plain", *kept])
        p(line + ("  *" if f in scene.keyframes[1:] else ""))
    losses = ", ".join(f"{-100 * plain.volume_change_plain[f]:.1f} % (frame {f})" for f in scene.keyframes[1:])
    worst = max(res[k].max_volume_error for k in kept)
    p(f"  * key frames: plain FFD loses {losses}; largest preserved error {worst:.1e}")
    p(f"  {scene.paper}")


def _plot(scenes, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axs = plt.subplots(2, len(scenes), figsize=(5.2 * len(scenes), 6.4), sharex="col",
                            gridspec_kw=dict(height_ratios=[2, 1]))
    axs = np.asarray(axs).reshape(2, len(scenes))
    styles = dict(plain=("k", "-"), xy=("tab:blue", "-"), z=("tab:orange", "--"), xyz=("tab:green", ":"))
    for c, s in enumerate(scenes):
        top, bot = axs[0, c], axs[1, c]
        frames = np.arange(s.frames)
        for k, r in s.results.items():
            col, ls = styles.get(k, ("gray", "-"))
            lab = _LABELS[k]
            y = r.volume_change_plain if not r.preserve else r.volume_change
            top.plot(frames, 100 * (1 + y), color=col, ls=ls, lw=2 if k == "plain" else 1.5, label=lab)
            if r.preserve:
                bot.semilogy(frames, np.maximum(np.abs(r.volume_change), 1e-17), color=col, ls=ls, marker=".",
                             label=lab)
        for f in s.keyframes[1:]:
            top.axvline(f, color="0.8", lw=0.8, zorder=0)
        top.set_title(s.title.split(":")[0])
        top.set_ylabel("volume, % of rest")
        top.legend(fontsize=8, loc="best")
        top.grid(alpha=0.3)
        bot.axhline(1e-10, color="r", lw=0.8, ls="--", label="1e-10 (tested bound)")
        bot.set_ylim(1e-17, 1e-8)
        bot.set_ylabel("|relative volume error|")
        bot.set_xlabel("frame")
        bot.legend(fontsize=7, loc="upper left")
        bot.grid(alpha=0.3)
    fig.tight_layout()
    with replaced_path(path, "demo") as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)


def _csv(scenes, path: Path) -> None:
    with open_replacing(path, "w", "demo", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["scene", "frame", "time_s", "parameter", "variant", "axes", "volume", "rest_volume",
                    "relative_change", "plain_relative_change"])
        for s in scenes:
            for k, r in s.results.items():
                for f, t in enumerate(r.times):
                    w.writerow([s.key, f, f"{t:.6f}", f"{s.param(t):.6f}", k, r.axes, repr(float(r.volumes[f])),
                                repr(float(r.rest_volume)), repr(float(r.volume_change[f])),
                                repr(float(r.volume_change_plain[f]))])


def run_demo(out="demo_out", quick: bool = False, render: bool = True, size=(320, 240), stream=None,
             progress=None, backend: str = "serial", motion: bool = True, multires: bool = True,
             subdiv: bool = True) -> dict:
    """Runs both animations with every variant, then the moving-object scenes
    (``vpffd.cli.motion``: a shoal round a ring, walkers on a Moebius band) and the
    multiresolution scene (``vpffd.cli.multires_scene``: a bumpy body bent, FFD of
    the fine mesh against the base + details edit), prints the tables and writes the
    pictures under ``out``.

    Parameters
    ----------
    out : str or Path
        output folder (created).
    quick : bool
        smaller meshes and fewer frames (for tests).
    render : bool
        write the PNG frames, GIFs and key-frame sheets (needs ``vpffd.render``).
    size : (width, height)
        pixels of one panel.
    stream : file, optional
        where the table goes (default stdout).
    progress : callable, optional
        ``progress(label, total) -> bar`` factory; bars are called as
        ``bar(done, total)`` and closed with ``bar.close()``.
    backend : str
        Deformer backend. Serial by default: on meshes of a few thousand
        vertices a frame takes a few milliseconds, less than waking threads
        costs on a busy machine.
    motion : bool
        also run the moving-object scenes (GIFs, ``motion_volume.png``/``.csv``).
    multires : bool
        also run the multiresolution scenes (``multires.gif``, ``multires.csv``,
        ``multires_details.png``).
    subdiv : bool
        also run the displaced subdivision surface scene (``subdiv.png``,
        ``subdiv.gif``, ``subdiv.csv``; skipped with a note when this build has no
        OpenSubdiv).

    Returns
    -------
    dict
        ``scenes`` (list of Scene with their results), ``motion_scenes`` (list of
        ``vpffd.cli.motion.MotionScene``), ``multires_scene`` (the
        ``vpffd.cli.multires_scene.MultiresScene`` or None), ``subdiv_scene`` (the
        ``vpffd.cli.subdiv_scene.SubdivScene`` or None), ``files`` (paths written),
        ``seconds``, ``rendered`` (bool).
    """
    stream = sys.stdout if stream is None else stream
    if render:  # before minutes of deforming, not when the first frame is drawn
        from ..camera import _size
        size = _size(size, "run_demo")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    scenes = [twisting_cube(quick), bouncing_ball(quick)]
    has_pil = importlib.util.find_spec("PIL") is not None
    has_mpl = importlib.util.find_spec("matplotlib") is not None
    can_render = render and has_pil and _renderer() is not None
    files = []
    print("vpffd demo: the paper's animations, plain FFD against exact volume preservation per axis restriction",
          file=stream)
    missing = [(name, what) for name, what, ok in (("Pillow", "frames or GIFs", has_pil or not render),
                                                    ("matplotlib", "volume plot", has_mpl)) if not ok]
    if missing:  # say so before minutes of deforming, not only at the end
        print(f"note: {' and '.join(m[0] for m in missing)} not installed, so no "
              f"{' and no '.join(m[1] for m in missing)} will be written; "
              'pip install "vpffd[demo]" brings what the pictures and the plot need', file=stream)
    for s in scenes:
        d = Deformer(s.mesh, s.lattice, backend=backend)
        with bar(progress, f"{s.key}: deforming", s.frames * len(VARIANTS)) as b:
            for i, (k, _label_, preserve, axes) in enumerate(VARIANTS):
                cb = (lambda done, total, i=i: b(i * total + done, len(VARIANTS) * total)) if b else None
                s.results[k] = run_animation(s.mesh, s.lattice, s.animator, s.frames, axes=axes or "xyz",
                                             preserve=preserve, deformer=d, progress=cb)
        _table(s, stream)
        if can_render:
            with bar(progress, f"{s.key}: rendering", s.frames * len(VARIANTS)) as b:
                files += _render_scene(s, out, size, progress=b)
    if has_mpl:
        _plot(scenes, out / "volume.png")
        files.append(out / "volume.png")
    _csv(scenes, out / "volume.csv")
    files.append(out / "volume.csv")
    moving = []
    if motion:
        from . import motion as mo
        print("\nObjects moving through a fixed deformation (GPU FFD paper, section 3): every frame moves the "
              "rest mesh, the control points stay", file=stream)
        for make in (mo.shoal, mo.mobius_walk):
            s = make(quick)
            with bar(progress, f"{s.key}: deforming", s.frames * len(mo.MOTION_VARIANTS)) as b:
                mo.run_motion(s, backend=backend, progress=b)
            mo.table(s, stream)
            if can_render:
                with bar(progress, f"{s.key}: rendering", s.frames * len(mo.MOTION_VARIANTS)) as b:
                    files += mo.render(s, out, size, progress=b)
            moving.append(s)
        if has_mpl:
            mo.plot(moving, out / "motion_volume.png")
            files.append(out / "motion_volume.png")
        mo.write_csv(moving, out / "motion_volume.csv")
        files.append(out / "motion_volume.csv")
    layered = None
    if multires:
        from . import multires_scene as ms
        print("\nMultiresolution editing (GPU multiresolution paper, sections 3-4): the smooth base goes through "
              "the FFD, the details follow its normals", file=stream)
        layered = ms.bent_body(quick)
        with bar(progress, f"{layered.key}: deforming", layered.frames) as b:
            ms.run(layered, backend=backend, progress=b)
        ms.table(layered, stream)
        if can_render:
            with bar(progress, f"{layered.key}: rendering", layered.frames * len(ms.PANELS)) as b:
                files += ms.render(layered, out, size, progress=b)
        ms.write_csv(layered, out / "multires.csv")
        files.append(out / "multires.csv")
        details = ms.detail_scene(quick, backend=backend)
        ms.detail_table(details, stream)
        if can_render:
            files.append(ms.write_detail_picture(details, out / "multires_details.png",
                                                 (max(3 * size[0], 900), max(size[1] + 200, 360))))
    displaced = None
    if subdiv:
        from ..subdivision import available as has_subdiv
        print("\nDisplaced subdivision surfaces (GPU multiresolution paper, section 5): control points move, the "
              "details follow the limit surface's normals", file=stream)
        if not has_subdiv():
            print("  skipped: this build has no subdivision surfaces (install libosd-dev and rebuild)", file=stream)
        else:
            from . import subdiv_scene as ss
            displaced = ss.pulled_body(quick)
            with bar(progress, f"{displaced.key}: deforming", displaced.frames) as b:
                ss.run(displaced, progress=b)
            ss.table(displaced, stream)
            if can_render:
                with bar(progress, f"{displaced.key}: rendering", displaced.frames) as b:
                    files += ss.render(displaced, out, size, progress=b)
            ss.write_csv(displaced, out / "subdiv.csv")
            files.append(out / "subdiv.csv")
    secs = time.perf_counter() - t0
    print("", file=stream)
    if not can_render:
        why = ("rendering switched off" if not render else
               'Pillow is not installed: pip install "vpffd[demo]" (Pillow and matplotlib)'
               if not has_pil else "this build has no renderer (vpffd.render needs Embree: install libembree-dev "
               "and rebuild)")
        print(f"no frames or GIFs written: {why}", file=stream)
    else:
        print(f"frames: {', '.join(str(out / s.key) + '/frame_*.png' for s in scenes)}", file=stream)
        print(f"GIFs and key frames: {', '.join(str(out / (s.key + '.gif')) for s in scenes)}, "
              f"{', '.join(str(out / (s.key + '_keyframes.png')) for s in scenes)}", file=stream)
        print("panels from left to right: " + " | ".join(v[1] for v in VARIANTS), file=stream)
        if moving:
            print(f"moving objects: {', '.join(str(out / (s.key + '.gif')) for s in moving)} "
                  f"(plain FFD | each object's volume kept; objects coloured by their volume change)", file=stream)
        if layered is not None:
            print(f"multiresolution: {out / 'multires.gif'} (FFD of the fine mesh | multiresolution | angle between "
                  f"its approximate and exact normals), {out / 'multires_details.png'} (what each does to the "
                  "details, measured)", file=stream)
        if displaced is not None:
            print(f"subdivision surface: {out / 'subdiv.png'}, {out / 'subdiv.gif'} (control mesh over the limit "
                  f"surface, rest | edited | detailed result | approximate normal error)", file=stream)
    plot = (f"volume plot: {out / 'volume.png'}" if has_mpl else
            'no volume plot: matplotlib is not installed (pip install "vpffd[demo]")')
    if moving and has_mpl:
        plot += f", {out / 'motion_volume.png'}"
    numbers = [out / "volume.csv"] + ([out / "motion_volume.csv"] if moving else []) + \
        ([out / "multires.csv"] if layered is not None else []) + \
        ([out / "subdiv.csv"] if displaced is not None else [])
    print(f"{plot}, numbers: {', '.join(map(str, numbers))}  ({secs:.1f} s)", file=stream)
    return dict(scenes=scenes, motion_scenes=moving, multires_scene=layered, subdiv_scene=displaced, files=files,
                seconds=secs,
                rendered=can_render)
