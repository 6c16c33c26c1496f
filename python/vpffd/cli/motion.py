"""The second paper's scenes (GPU FFD, §2.3 and §3): objects moving *through* a
fixed deformation, each keeping its own volume.

- ``shoal``: fish swimming round a closed ring lattice (periodic along x, seam
  "closed") whose tube narrows and widens three times per lap: a plain FFD
  squeezes and inflates every fish as it passes; with ``parts="components"``
  every fish keeps its volume exactly.
- ``mobius_walk``: a line of creatures walking along a Moebius band (periodic
  along x, seam "twist"): after one lap they come back on the other side.

Every frame moves the objects' rest positions (``animate.PathOffset`` and
``Deformer.set_rest_offsets``: each moving object by the path's offset, the still
ones by none); the control points never change. Writes, under
``out``: ``<scene>.gif`` and ``<scene>/frame_NNN.png`` (plain FFD | each object's
volume kept, objects coloured by their volume change), ``motion_volume.png``
(every object's volume over time, with and without preservation) and
``motion_volume.csv``.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import edits, shapes
from .._files import open_replacing, replaced_path
from ..animate import PathOffset
from ..deformer import Deformer
from ..lattice import Lattice
from ..mesh import Mesh

# (key, label, preserve)
MOTION_VARIANTS = (("plain", "plain FFD", False), ("kept", "each object's volume kept", True))


@dataclass
class MotionScene:
    """Objects (one mesh, one component each, plus optional still parts) moving
    through a lattice whose control points stay fixed."""
    key: str
    title: str
    mesh: Mesh                  # every object, in its rest position at t = 0
    moving: np.ndarray          # (V,) bool: vertices the path moves
    names: list                 # one name per component, in the Deformer's part order
    lattice: Lattice
    control_points: np.ndarray  # (nu, nv, nw, 3), distinct points of the periodic lattice
    path: PathOffset
    frames: int
    duration: float             # seconds
    view: tuple
    results: dict = field(default_factory=dict)  # variant -> dict of arrays (see run_motion)
    vertex_parts: np.ndarray = None  # (V,) part index of each vertex, set by run_motion

    def times(self) -> np.ndarray:
        return np.linspace(0.0, self.duration, self.frames)

    def rest_positions(self, t: float) -> np.ndarray:
        """(V, 3) rest vertices at time ``t``: the moving ones shifted along the path."""
        X = self.mesh.vertices.copy()
        X[self.moving] = self.path.positions(X[self.moving], t)
        return X

    def part_offsets(self, t: float, vertex_parts: np.ndarray) -> np.ndarray:
        """(K, 3) the offset of each part at time ``t`` (``vertex_parts``: the
        Deformer's part of every vertex): the path's for a moving object, zero for a
        still one. ``Deformer.set_rest_offsets`` of these gives ``rest_positions(t)``."""
        K = int(vertex_parts.max()) + 1
        moving = np.zeros(K, bool)
        moving[vertex_parts[self.moving]] = True
        if np.any(moving[vertex_parts[~self.moving]]):
            raise AssertionError(f"{self.key}: an object is partly moving")
        return np.where(moving[:, None], self.path.offset(t), 0.0)


def _join(meshes) -> Mesh:
    V, F, off = [], [], 0
    for m in meshes:
        V.append(m.vertices)
        F.append(m.faces + off)
        off += m.n_vertices
    return Mesh(np.concatenate(V), np.concatenate(F).astype(np.int32))


def _moved(m: Mesh, shift, scale=(1.0, 1.0, 1.0)) -> Mesh:
    return Mesh(m.vertices * np.asarray(scale, dtype=np.float64) + np.asarray(shift, dtype=np.float64), m.faces)


def shoal(quick: bool = False, n_fish: int = 4, fish: Mesh = None) -> MotionScene:
    """Fish circling a ring lattice whose tube narrows and widens three times per lap.
    ``fish``: the creature (default ``shapes.fish``; length 1 along x, centred)."""
    if fish is None:
        fish = shapes.fish(12, 24) if quick else shapes.fish(24, 48)
    spacing = 1.6
    L = spacing * n_fish
    lat = Lattice((0.0, -0.36, -0.48), (L, 0.36, 0.48), shape=(12 if quick else 18, 4, 4), degree=3,
                  periodic="x", seam="closed")
    P = edits.ring(lat)
    # Scale each cross-section about its centre by 1 + a sin(3 theta): a tube that
    # pinches three times round the ring, so the plain FFD changes each fish's volume.
    n = P.shape[0]
    theta = 2 * np.pi * np.arange(n) / n
    centre = P.mean(axis=(1, 2), keepdims=True)
    P = centre + (P - centre) * (1.0 + 0.3 * np.sin(3 * theta))[:, None, None, None]
    school = _join([_moved(fish, ((i + 0.5) * spacing, 0.0, 0.0)) for i in range(n_fish)])
    frames = 10 if quick else 48
    duration = 4.0
    # A third of a lap: every fish swims through one narrowing and one widening.
    path = PathOffset(lat, "x", speed=(L / 3) / duration)
    return MotionScene("shoal", f"Shoal: {n_fish} fish ({fish.n_vertices:,} vertices each) round a closed ring "
                       f"lattice {lat.shape[0]}x4x4 that narrows and widens",
                       school, np.ones(school.n_vertices, bool), [f"fish {i + 1}" for i in range(n_fish)],
                       lat, P, path, frames, duration, (0.35, -1.0, 0.9))


def mobius_walk(quick: bool = False, n_walkers: int = 7, walker: Mesh = None, band: bool = True) -> MotionScene:
    """Creatures walking along a Moebius band: one lap brings them back on the other side.
    ``walker``: the creature (default ``shapes.fish``); ``band``: include the band's slab."""
    L = 8.0
    lat = Lattice((0.0, -0.5, -0.4), (L, 0.5, 0.4), shape=(14 if quick else 20, 4, 4), degree=3,
                  periodic="x", seam="twist")
    P = edits.mobius(lat, radius=1.6)
    # The band: a thin slab on the box's mid-plane along its whole length, so that the
    # half twist closes it on itself (ends kept apart by a hair: no vertex on the seam).
    eps = 1e-3 * L
    slab = [_moved(shapes.box(8 if quick else 20), (0.5 * L, 0.0, 0.0), (L - 2 * eps, 0.9, 0.1))] if band else []
    if walker is None:
        walker = shapes.fish(10, 20) if quick else shapes.fish(16, 32)
    spacing = 0.6
    walkers = [_moved(walker, (0.6 + i * spacing, 0.0, 0.21), (0.45, 0.9, 0.5)) for i in range(n_walkers)]
    mesh = _join([*slab, *walkers])
    moving = np.zeros(mesh.n_vertices, bool)
    moving[sum(m.n_vertices for m in slab):] = True
    frames = 10 if quick else 60
    duration = 6.0
    path = PathOffset(lat, "x", speed=L / duration)  # one lap: they come back upside down
    return MotionScene("mobius_walk", f"Moebius walk: {n_walkers} walkers ({walker.n_vertices:,} vertices each) "
                       f"on a band, lattice {lat.shape[0]}x4x4 periodic with a half twist",
                       mesh, moving, ["band"] * band + [f"walker {i + 1}" for i in range(n_walkers)],
                       lat, P, path, frames, duration, (0.5, -0.8, 0.9))


def run_motion(scene: MotionScene, backend: str = "serial", progress=None) -> MotionScene:
    """Deforms every frame in both variants; fills ``scene.results[variant]`` with
    ``vertices`` (frames, V, 3), ``volumes`` (frames, K) per object, ``rest``
    (frames, K) each object's rest volume, ``times`` and ``seconds`` (per frame,
    moving the rest mesh included)."""
    import time
    times = scene.times()
    total = len(MOTION_VARIANTS) * scene.frames
    for vi, (key, _label, preserve) in enumerate(MOTION_VARIANTS):
        d = Deformer(scene.mesh, scene.lattice, backend=backend, parts="components")
        if len(scene.names) != d.n_parts:
            raise AssertionError(f"{scene.key}: {d.n_parts} components, expected {len(scene.names)}")
        scene.vertex_parts = d.vertex_parts
        V, vols, rest, secs = [], [], [], []
        for f, t in enumerate(times):
            t0 = time.perf_counter()
            d.set_rest_offsets(scene.part_offsets(t, scene.vertex_parts))
            r = d.deform(scene.control_points, preserve_volume=preserve, axes="xyz")
            secs.append(time.perf_counter() - t0)
            V.append(r.vertices)
            vols.append(r.part_volumes)
            rest.append(d.rest_part_volumes)
            if progress:
                progress(vi * scene.frames + f + 1, total)
        scene.results[key] = dict(vertices=np.stack(V), volumes=np.stack(vols), rest=np.stack(rest),
                                  times=times, seconds=np.array(secs), preserve=preserve)
    return scene


def _change(res) -> np.ndarray:
    """(frames, K) relative volume change of every object."""
    return res["volumes"] / res["rest"] - 1.0


def table(scene: MotionScene, stream) -> None:
    p = lambda s: print(s, file=stream)  # noqa: E731
    plain, kept = scene.results["plain"], scene.results["kept"]
    cp, ck = _change(plain), _change(kept)
    p("")
    p(scene.title)
    p(f"  {scene.mesh.n_vertices:,} vertices, {len(scene.names)} objects; every frame moves the rest mesh "
      f"(set_rest_offsets) and deforms it, control points fixed")
    p(f"  {'object':>10} {'plain FFD: min':>15} {'max':>8} {'kept: max |error|':>19}")
    for i, name in enumerate(scene.names):
        p(f"  {name:>10} {100 * cp[:, i].min():+14.1f}% {100 * cp[:, i].max():+7.1f}% {np.abs(ck[:, i]).max():19.1e}")
    p(f"  frame time (median, moving the rest mesh included): plain {1e3 * np.median(plain['seconds']):.1f} ms, "
      f"kept {1e3 * np.median(kept['seconds']):.1f} ms")


def plot(scenes, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axs = plt.subplots(1, len(scenes), figsize=(5.6 * len(scenes), 3.8), squeeze=False)
    for ax, s in zip(axs[0], scenes):
        t = s.results["plain"]["times"]
        cp, ck = _change(s.results["plain"]), _change(s.results["kept"])
        colors = plt.cm.tab10(np.arange(len(s.names)) % 10)
        for i, name in enumerate(s.names):
            ax.plot(t, 100 * (1 + cp[:, i]), color=colors[i], lw=1.4, label=f"{name}, plain")
            ax.plot(t, 100 * (1 + ck[:, i]), color=colors[i], lw=1.0, ls="--")
        ax.plot([], [], color="k", ls="--", lw=1.0, label="every object, kept")
        ax.set_title(s.title.split(":")[0])
        ax.set_xlabel("time (s)")
        ax.set_ylabel("volume, % of rest")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=2, loc="best")
    fig.tight_layout()
    with replaced_path(path, "motion") as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)


def write_csv(scenes, path: Path) -> None:
    with open_replacing(path, "w", "motion", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["scene", "frame", "time_s", "variant", "object", "volume", "rest_volume", "relative_change"])
        for s in scenes:
            for key, res in s.results.items():
                for f, t in enumerate(res["times"]):
                    for i, name in enumerate(s.names):
                        v, r0 = float(res["volumes"][f, i]), float(res["rest"][f, i])
                        w.writerow([s.key, f, f"{t:.6f}", key, name, repr(v), repr(r0), repr(v / r0 - 1.0)])


def render(scene: MotionScene, out: Path, size, progress=None) -> list:
    """Frames (plain | kept, each object coloured by its volume change), the GIF.
    Returns the written paths."""
    from PIL import Image

    from ..colormap import volume_change_colors
    from ..comparison import fit_camera
    from ..rendering import render as draw
    from .frames import frame_dir, label as _label, save_frame, write_gif
    w, h = size
    keys = [k for k, _, _ in MOTION_VARIANTS]
    labels = {k: lab for k, lab, _ in MOTION_VARIANTS}
    pts = np.concatenate([scene.results[k]["vertices"].reshape(-1, 3) for k in keys])
    cam = fit_camera(pts[:: max(1, len(pts) // 200000)], up="z", size=(w, h), direction=scene.view)
    part = scene.vertex_parts
    # One colour scale for the whole animation: the largest change of any object.
    ratio = {k: scene.results[k]["volumes"] / scene.results[k]["rest"] for k in keys}
    limit = max(1.05, float(np.exp(np.abs(np.log(ratio["plain"])).max())))
    fdir = frame_dir(out, scene.key, scene.frames)
    written, gif = [], []
    faces = scene.mesh.faces
    for f in range(scene.frames):
        row = Image.new("RGB", (w * len(keys), h), "white")
        for i, k in enumerate(keys):
            res = scene.results[k]
            colors = volume_change_colors(ratio[k][f][part], limit)
            img = draw(Mesh(res["vertices"][f], faces), camera=cam, lattice=scene.lattice, size=(w, h),
                       control_points=scene.control_points, colors=colors, samples=2, points=False,
                       line_color=(0.30, 0.36, 0.50), line_alpha=0.25, hidden_alpha=0.3)
            change = 100 * (ratio[k][f] - 1)
            worst = change[np.argmax(np.abs(change))]
            note = (f"largest object change {worst:+.1f} %" if not res["preserve"] else
                    f"largest error {np.abs(ratio[k][f] - 1).max():.0e}")
            row.paste(_label(Image.fromarray(np.ascontiguousarray(img)), [labels[k], note]), (i * w, 0))
            if progress:
                progress(f * len(keys) + i + 1, scene.frames * len(keys))
        _label(row, ["", "", f"frame {f}  t = {scene.results[keys[0]]['times'][f]:.2f} s"])
        written.append(save_frame(fdir, f, row))
        gif.append(row)
    written.append(write_gif(gif, out / f"{scene.key}.gif", scene.duration / max(scene.frames - 1, 1)))
    return written
