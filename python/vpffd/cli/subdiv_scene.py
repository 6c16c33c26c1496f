"""The demo's displaced subdivision surface scene (Marinov et al., §5): a detailed body
(a bumpy sphere stretched along x, made in code) decomposed into a Loop control mesh
of a few hundred points, its limit surface and a normal displacement per vertex;
the three control points at the front are pulled out along +x over a few frames and
the details are rebuilt on the deformed limit surface.

Every frame is four panels (``vpffd.subdivision_picture``): the rest control mesh
over its limit surface, the edited control mesh over the deformed limit surface, the
detailed result, and the result coloured by the angle between its approximate
normals (eqs. 6-7) and the normals of the deformed mesh. Writes, under ``out``:
``subdiv.png`` (the last frame), ``subdiv.gif``, ``subdiv/frame_NNN.png`` and
``subdiv.csv``, and prints a table per frame.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import shapes
from .._files import open_replacing, replaced_path
from ..mesh import Mesh
from ..subdivision import SubdivisionMultires
from ..subdivision_picture import edit_captions, edit_numbers, normal_error_deg

# How far the front control points go at the last frame, in lengths of the body.
PULL = 0.22
MOVED = 3  # control points pulled


@dataclass
class SubdivScene:
    key: str
    title: str
    mesh: Mesh
    control_vertices: int
    frames: int
    results: dict = field(default_factory=dict)


def pulled_body(quick: bool = False) -> SubdivScene:
    """A bumpy body (bumpy_sphere stretched 1.6:1:1) with a Loop control mesh."""
    mesh = shapes.bumpy_sphere(4 if quick else 5, amplitude=0.05, frequency=10.0, stretch=(1.6, 1.0, 1.0))
    n = 120 if quick else 250
    return SubdivScene("subdiv", f"Displaced subdivision surface: bumpy body, {mesh.n_vertices:,} vertices, Loop "
                       f"control mesh of about {n} points, {MOVED} control points pulled out", mesh, n,
                       3 if quick else 7)


def run(scene: SubdivScene, progress=None) -> SubdivScene:
    """Decomposes the mesh and deforms every frame; fills ``scene.results``:
    ``decomposition`` (the SubdivisionMultires), ``moved`` (the pulled control
    points), ``control_points`` (frames, M, 3), ``results`` (the frames'
    MultiresResult), ``angles`` (frames, V) degrees, ``numbers`` (EditNumbers per
    frame), ``frame_ms`` (frames,) and ``pull`` (frames,) the offsets along x."""
    import time
    sm = SubdivisionMultires(scene.mesh, scheme="loop", control_vertices=scene.control_vertices)
    C0 = sm.control_points
    moved = np.argsort(C0[:, 0])[-MOVED:]  # the front: largest x
    length = float(np.ptp(scene.mesh.vertices[:, 0]))
    pulls = np.linspace(0.0, PULL * length, scene.frames)
    out = {k: [] for k in ("control_points", "results", "angles", "numbers", "frame_ms")}
    for f, pull in enumerate(pulls):
        C = np.array(C0)
        C[moved, 0] += pull
        t0 = time.perf_counter()
        r = sm.deform(C)
        out["frame_ms"].append(1e3 * (time.perf_counter() - t0))
        a = normal_error_deg(r, scene.mesh.faces)
        out["control_points"].append(C)
        out["results"].append(r)
        out["angles"].append(a)
        out["numbers"].append(edit_numbers(sm, r, a))
        if progress:
            progress(f + 1, scene.frames)
    scene.results = dict(decomposition=sm, moved=moved, pull=pulls, control_points=np.array(out["control_points"]),
                         results=out["results"], angles=np.array(out["angles"]), numbers=out["numbers"],
                         frame_ms=np.array(out["frame_ms"]))
    return scene


def top_degrees(scene: SubdivScene) -> float:
    """The colour scale's end: the largest normal error of the animation, at least 1 degree."""
    return max(1.0, float(np.nanmax(scene.results["angles"])))


def captions(scene: SubdivScene, f: int) -> list:
    """(title, numbers) of frame f's four panels."""
    return edit_captions(scene.results["numbers"][f], top_degrees(scene))


def table(scene: SubdivScene, stream) -> None:
    p = lambda s: print(s, file=stream)  # noqa: E731
    r = scene.results
    sm = r["decomposition"]
    p("")
    p(scene.title)
    p(f"  {sm.n_control} control points, fit RMS |p - S| {sm.rms_initial:.3g} -> {sm.rms_final:.3g}, "
      f"{len(sm.unresolved)} unresolved foot points, decomposed in {sm.seconds:.2f} s, "
      f"{sm.bytes_per_vertex:.0f} bytes per vertex per frame")
    p(f"  {'frame':>5} {'pull':>7} {'volume':>9} {'normals: mean':>14} {'max':>7} {'frame ms':>9}")
    for f, n in enumerate(r["numbers"]):
        p(f"  {f:>5} {r['pull'][f]:7.3f} {100 * n.volume_change:+8.2f}% {n.normal_mean:13.3f}° "
          f"{n.normal_max:6.2f}° {r['frame_ms'][f]:9.2f}")
    p("  pull: how far the front control points moved along x; volume: change of the detailed mesh (not "
      "preserved here); normals: approximate (eqs. 6-7) against the deformed mesh's")


def write_csv(scene: SubdivScene, path: Path) -> None:
    r = scene.results
    with open_replacing(path, "w", "subdiv", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["frame", "pull", "control_points_moved", "volume_change", "normal_angle_mean_deg",
                    "normal_angle_max_deg", "frame_ms"])
        for f, n in enumerate(r["numbers"]):
            w.writerow([f, repr(float(r["pull"][f])), n.moved, repr(float(n.volume_change)),
                        repr(n.normal_mean), repr(n.normal_max), repr(float(r["frame_ms"][f]))])


def render(scene: SubdivScene, out: Path, size, progress=None) -> list:
    """Every frame's four panels (each ``size`` pixels), the GIF and ``subdiv.png``
    (the last frame); the paths written."""
    from PIL import Image

    from ..subdivision_picture import render_subdivision_edit
    from .frames import frame_dir, save_frame, write_gif
    w, h = size
    r = scene.results
    sm = r["decomposition"]
    top = top_degrees(scene)
    fdir = frame_dir(out, scene.key, scene.frames)
    written, gif = [], []
    for f in range(scene.frames):
        img = render_subdivision_edit(sm, r["results"][f], size=(4 * w, h), up="z", angles=r["angles"][f],
                                      top=top, captions=captions(scene, f))
        pic = Image.fromarray(img)
        written.append(save_frame(fdir, f, pic))
        gif.append(pic)
        if progress:
            progress(f + 1, scene.frames)
    written.append(write_gif(gif, Path(out) / f"{scene.key}.gif", 0.4))
    last = Path(out) / f"{scene.key}.png"
    with replaced_path(last, "subdiv") as tmp:
        gif[-1].save(tmp, format="PNG")
    written.append(last)
    return written
