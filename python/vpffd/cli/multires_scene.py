"""The third paper's scene (GPU multiresolution deformation, §3-4): a detailed body
bent by a lattice, deformed two ways.

- "FFD of the fine mesh": every vertex goes through the FFD, the volume kept exactly;
  the bumps are sheared and stretched with the space around them.
- "multiresolution": the smooth base surface goes through the FFD (its volume kept
  exactly) and every vertex is rebuilt at its normal displacement from the deformed
  base, with its normal from the six per-vertex coefficients (eqs. 6-7), no
  neighbours needed; the bumps stay upright on the bent surface.

The third panel colours the multiresolution mesh by the angle between those
approximate normals and the normals recomputed from the deformed mesh (what the
approximation costs). Writes, under ``out``: ``multires.gif``,
``multires/frame_NNN.png`` and ``multires.csv``, and prints a table per frame.

The still picture (``detail_scene``, ``multires_details.png``; the paper's Fig. 6):
a bumpy ball squashed to DETAIL_SQUASH of its height, volume kept, rest | FFD of
the fine mesh | multiresolution, captioned with how much the details' height and
direction changed (``vpffd.detail_change``): the FFD flattens the bumps on top
and tilts those on the flanks; the multiresolution edit keeps them.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import _core, edits, shapes
from .._files import open_replacing
from ..animate import Bend
from ..deformer import Deformer
from ..lattice import Lattice
from ..mesh import Mesh
from ..multires import Multires, MultiresDeformer
from ..multires_picture import detail_captions

# (key, label)
PANELS = (("ffd", "FFD of the fine mesh, volume kept"), ("multires", "multiresolution, base volume kept"),
          ("normals", "approximate vs exact normals"))
BEND_DEG = 150.0


@dataclass
class MultiresScene:
    key: str
    title: str
    mesh: Mesh
    lattice: Lattice
    animator: Bend
    frames: int
    smoothing: float
    results: dict = field(default_factory=dict)


def bent_body(quick: bool = False) -> MultiresScene:
    """A bumpy elongated sphere (bumpy_sphere stretched 2:1:1), bent to BEND_DEG."""
    mesh = shapes.bumpy_sphere(3 if quick else 5, amplitude=0.08, frequency=10.0, stretch=(2.4, 1.0, 1.0))
    lat = Lattice.around(mesh, shape=(7, 4, 4), degree=3, padding=0.05)
    frames = 5 if quick else 21
    anim = Bend(lat, angle=BEND_DEG, axis="x", toward="z", duration=2.0)
    return MultiresScene("multires", f"Multiresolution editing: bumpy body, {mesh.n_vertices:,} vertices, "
                         f"lattice 7x4x4 cubic, bent to {BEND_DEG:.0f} deg", mesh, lat, anim, frames, 10.0)


def _angles_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per-row angle between unit vectors, degrees (atan2 form: accurate near 0)."""
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b)))


def run(scene: MultiresScene, backend: str = "serial", progress=None) -> MultiresScene:
    """Deforms every frame both ways; fills ``scene.results`` with per-frame arrays:
    ``ffd`` and ``multires`` vertices (frames, V, 3), ``angles`` (frames, V) degrees,
    and the volume errors of both (and of the multiresolution base)."""
    mr = Multires(scene.mesh, smoothing=scene.smoothing)
    md = MultiresDeformer(mr, scene.lattice, backend=backend)
    d = Deformer(scene.mesh, scene.lattice, backend=backend)
    times = np.linspace(0.0, scene.animator.duration, scene.frames)
    out = {k: [] for k in ("ffd", "multires", "angles", "ffd_error", "multires_error", "base_error", "plain_change")}
    for f, t in enumerate(times):
        P = scene.animator(t)
        r = d.deform(P, axes="xyz")
        m = md.deform(P, axes="xyz", volume="base")
        exact = _core.vertex_normals(m.vertices, scene.mesh.faces)
        out["ffd"].append(r.vertices)
        out["multires"].append(m.vertices)
        out["angles"].append(_angles_deg(m.normals, exact))
        out["ffd_error"].append(r.volume_error)
        out["multires_error"].append(m.volume_error)
        out["base_error"].append(m.base_volume_error)
        out["plain_change"].append(r.volume_before / r.rest_volume - 1.0)
        if progress:
            progress(f + 1, scene.frames)
    scene.results = {k: np.array(v) for k, v in out.items()}
    scene.results["times"] = times
    scene.results["decomposition"] = mr
    # What the last frame did to the details (a bend is nearly isometric on the body,
    # so the FFD of the fine mesh changes them little: why the two look alike).
    scene.results["details"] = detail_captions(md, r, m)
    return scene


def table(scene: MultiresScene, stream) -> None:
    p = lambda s: print(s, file=stream)  # noqa: E731
    r = scene.results
    mr = r["decomposition"]
    p("")
    p(scene.title)
    p(f"  base: cotangent fairing, smoothing {scene.smoothing:g}; {mr.frame_bytes_per_vertex} bytes per vertex of "
      f"frame data; foot-point residual max {mr.residuals.max():.1e}")
    p(f"  {'frame':>5} {'bend deg':>8} {'plain FFD':>10} {'FFD kept':>9} {'multires':>9} {'its base':>9} "
      f"{'normals: mean':>14} {'max':>6}")
    for f, t in enumerate(r["times"]):
        a = r["angles"][f]
        p(f"  {f:>5} {BEND_DEG * t / scene.animator.duration:8.1f} {100 * r['plain_change'][f]:+9.2f}% "
          f"{r['ffd_error'][f]:9.1e} {r['multires_error'][f]:9.1e} {r['base_error'][f]:9.1e} "
          f"{a.mean():13.3f}° {a.max():5.2f}°")
    p("  volume columns: plain FFD as change, the others as relative error against the rest volume; the "
      "multiresolution mesh keeps its base's volume, not its own")
    c, k = r["details"]["plain"], r["details"]["multires"]
    p(f"  details at the last frame: the FFD of the fine mesh changed their height by "
      f"{100 * c.height_change_mean:.1f} % and tilted them {c.angle_mean_deg:.1f} deg from the base normal (mean), the multiresolution edit by "
      f"{100 * k.height_change_mean:.1g} % and {k.angle_mean_deg:.1g} deg: a bend barely stretches the body, a "
      "squash does (below)")
    p("  paper (002, Fig. 2 and §4.1): mean normal error about 1 deg for moderate edits, at most 5 deg for "
      "extreme ones")


def write_csv(scene: MultiresScene, path: Path) -> None:
    r = scene.results
    with open_replacing(path, "w", "multires", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["frame", "time_s", "bend_deg", "plain_ffd_change", "ffd_kept_error", "multires_error",
                    "multires_base_error", "normal_angle_mean_deg", "normal_angle_max_deg"])
        for f, t in enumerate(r["times"]):
            w.writerow([f, f"{t:.6f}", f"{BEND_DEG * t / scene.animator.duration:.6f}",
                        repr(float(r["plain_change"][f])), repr(float(r["ffd_error"][f])),
                        repr(float(r["multires_error"][f])), repr(float(r["base_error"][f])),
                        repr(float(r["angles"][f].mean())), repr(float(r["angles"][f].max()))])


def render(scene: MultiresScene, out: Path, size, progress=None) -> list:
    """Frames (FFD | multiresolution | normal error map) and the GIF; the paths written."""
    from PIL import Image

    from ..colormap import colormap
    from ..comparison import fit_camera
    from ..rendering import render as draw
    from .frames import frame_dir, label as _label, save_frame, write_gif
    w, h = size
    r = scene.results
    faces = scene.mesh.faces
    pts = np.concatenate([r["ffd"].reshape(-1, 3), r["multires"].reshape(-1, 3)])
    cam = fit_camera(pts[:: max(1, len(pts) // 200000)], up="z", size=(w, h), direction=(0.15, -1.0, 0.35),
                     margin=1.25)  # room for the labels above the body
    # One scale for the whole animation: 0 to the largest angle seen (at least 1 degree).
    top = max(1.0, float(r["angles"].max()))
    grey = np.full((scene.mesh.n_vertices, 3), 0.78)
    fdir = frame_dir(out, scene.key, scene.frames)
    written, gif = [], []
    for f in range(scene.frames):
        row = Image.new("RGB", (w * len(PANELS), h), "white")
        for i, (k, label) in enumerate(PANELS):
            V = r["ffd"][f] if k == "ffd" else r["multires"][f]
            colors = colormap(r["angles"][f], "viridis", 0.0, top) if k == "normals" else grey
            img = draw(Mesh(V, faces), camera=cam, size=(w, h), colors=colors, samples=2)
            if k == "ffd":
                note = f"volume error {r['ffd_error'][f]:.0e}"
            elif k == "multires":
                note = f"volume {100 * (r['multires_error'][f]):.2f} % off (base exact)"
            else:
                note = f"mean {r['angles'][f].mean():.2f} deg, max {r['angles'][f].max():.1f} (scale 0-{top:.1f})"
            row.paste(_label(Image.fromarray(np.ascontiguousarray(img)), [label, note]), (i * w, 0))
            if progress:
                progress(f * len(PANELS) + i + 1, scene.frames * len(PANELS))
        _label(row, ["", "", f"frame {f}  bend {BEND_DEG * r['times'][f] / scene.animator.duration:.0f} deg"])
        written.append(save_frame(fdir, f, row))
        gif.append(row)
    written.append(write_gif(gif, out / f"{scene.key}.gif", scene.animator.duration / max(scene.frames - 1, 1)))
    return written


# The still picture: the ball's height scaled by this factor (volume kept).
DETAIL_SQUASH = 0.35


@dataclass
class DetailScene:
    """One edit done both ways: ``plain`` (DeformResult of the fine mesh), ``result``
    (MultiresResult), ``numbers`` (``detail_captions``: "plain" and "multires"
    DetailChange, measured on these results)."""
    title: str
    deformer: MultiresDeformer
    plain: object
    result: object
    numbers: dict


def detail_scene(quick: bool = False, backend: str = "serial") -> DetailScene:
    """A bumpy ball (bumps up to 10 % of its radius, about 0.26 radii apart) squashed
    to DETAIL_SQUASH of its height by a 5x5x5 cubic lattice, the volume kept: the FFD
    of the fine mesh (xyz correction) against the multiresolution edit (base volume
    kept)."""
    mesh = shapes.bumpy_sphere(3 if quick else 4, amplitude=0.1, frequency=12.0)
    lat = Lattice.around(mesh, shape=5, degree=3, padding=0.05)
    P = edits.squash(lat.rest_points, DETAIL_SQUASH, axis="z")
    md = MultiresDeformer(Multires(mesh, smoothing=10), lat, backend=backend)
    plain = Deformer(mesh, lat, backend=backend).deform(P, axes="xyz")
    result = md.deform(P, axes="xyz", volume="base")
    title = (f"Multiresolution editing: a bumpy ball ({mesh.n_vertices:,} vertices) squashed to "
             f"{DETAIL_SQUASH:g} of its height, volume kept")
    return DetailScene(title, md, plain, result, detail_captions(md, plain, result))


def detail_table(scene: DetailScene, stream) -> None:
    p = lambda s: print(s, file=stream)  # noqa: E731
    p("")
    p(scene.title)
    p(f"  {'':<22} {'detail height change':>21} {'tilt from base normal':>22}")
    for key, name in (("plain", "FFD of the fine mesh"), ("multires", "multiresolution")):
        c = scene.numbers[key]
        p(f"  {name:<22} {100 * c.height_change_mean:8.3g} % (max {100 * c.height_change_max:7.2g} %) "
          f"{c.angle_mean_deg:8.3g} deg (max {c.angle_max_deg:7.2g})")
    n = scene.numbers["plain"].n_measured
    p(f"  measured on the {n:,} vertices whose |d| is at least a fifth of the largest")


def write_detail_picture(scene: DetailScene, path: Path, size=(1500, 560)) -> Path:
    """rest | FFD of the fine mesh | multiresolution, with the measured captions (PNG)."""
    from .._png import save_png
    from ..multires_picture import render_multires_comparison
    img = render_multires_comparison(scene.deformer, scene.plain, scene.result, size=size, up="z",
                                     direction=(0.3, -1.0, 0.8), title=scene.title)
    save_png(path, img)
    return Path(path)
