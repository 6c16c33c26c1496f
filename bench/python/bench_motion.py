#!/usr/bin/env python
"""Frames per second of the GPU-FFD paper's three moving-object scenes (Schein and
Elber, §3) at its vertex counts, with the per-frame embedding included.

    .venv/bin/python bench/python/bench_motion.py [--frames 20] [--backends serial openmp vulkan] [--md out.md]

Scenes (meshes generated in code, the paper's counts):
  * whales: 4 x 28,212 = 112,848 vertices (fish, uv_sphere(218, 130)) round a closed
    ring lattice 18x4x4 whose tube narrows and widens; paper: 7.5 fps;
  * ants:   7 x 10,500 = 73,500 vertices (fish, uv_sphere(182, 58)) along a Moebius
    band lattice 20x4x4; paper: 8.4 fps;
  * car:    66,002 vertices (a stretched uv_sphere(201, 330); paper: 66,000) driving
    over a terrain lattice 16x6x4 periodic along x; paper: 5.5 fps;
  * car-open: the same car and terrain on an open (non-periodic) lattice, driving
    from x = 2 to x = 8 without wrapping (no seam: beside "car", what the periodic
    ties and the wrap cost), its rest mesh moved on the device each frame on Vulkan.
  * sphere: 163,842 vertices (icosphere(7)) drifting diagonally through an 8x8x8 cubic
    lattice under a twist: a larger mesh than the paper's, where the cost of moving
    the rest mesh against a frame is measured (far below a frame).
  * drag: the whales, one of them swimming and the other three still (an object moved
    among others): by offsets or by positions, only that whale is embedded again.
Per scene, backend and kind of move: the median over ``--frames`` frames of moving the
rest mesh (``set_rest_vertices`` with the moved positions, or ``set_rest_offsets`` with
the path's offset: on Vulkan only the offsets travel, and the rest volumes stay those of
construction), of the frame (``deform``, plain and with every object's
volume kept, ``parts="components"``), the fps of both together,
and the move's cost as a fraction of each frame. On Vulkan a move's device work
(embedding, cell sort, tiles) runs first in the next frame's submission: its
timestamps (``last_timings()["gpu_move_ms"]``) move it from the frame's column to
the move's, which is then the host's part plus the device's (each shown on its own too:
"of which on the host" is ``set_rest_vertices`` itself, all of a CPU move, and on a GPU
the part no device speed hides; the last column sets it against the frame). The paper's
figures (7.5, 8.4 and 5.5 fps) come from its own GPU (a GeForce 6800, 2006):
they are not printed beside ours, which come from another machine. On lavapipe (Vulkan on the CPU) the Vulkan
figures are functional, not GPU speeds. The load average is printed: compare
only figures from one run.
"""
import argparse
import os
import platform
import time

import numpy as np

import vpffd
from vpffd._files import open_replacing  # checked writes: a failure leaves the old file
from vpffd import animate, edits, shapes
from vpffd.cli import motion
from vpffd.cli.motion import _moved
from vpffd.cli.benchmark import run_for

def whales():
    s = motion.shoal(fish=shapes.fish(218, 130))            # the demo's shoal at the paper's count
    return s.mesh, s.lattice, s.control_points, s.path


def ants():
    s = motion.mobius_walk(walker=shapes.fish(182, 58), band=False)  # the paper counts the ants only
    return s.mesh, s.lattice, s.control_points, s.path


def car():
    body = shapes.uv_sphere(201, 330)
    L = 12.0
    lat = vpffd.Lattice((0.0, -1.0, -0.2), (L, 1.0, 1.2), shape=(16, 6, 4), degree=3, periodic="x", seam="shift")
    P = edits.terrain(lat, lambda x, y: 0.35 * np.sin(2 * np.pi * 2 * x / L) * np.cos(0.8 * y))
    mesh = _moved(Mesh(body.vertices[:, [2, 0, 1]], body.faces), (2.0, 0.0, 0.4), (1.2, 0.5, 0.3))
    return mesh, lat, P, animate.PathOffset(lat, "x", speed=L / 5.0)


def car_open():
    body = shapes.uv_sphere(201, 330)
    L = 12.0
    lat = vpffd.Lattice((0.0, -1.0, -0.2), (L, 1.0, 1.2), shape=(16, 6, 4), degree=3)
    P = edits.terrain(lat, lambda x, y: 0.35 * np.sin(2 * np.pi * 2 * x / L) * np.cos(0.8 * y))
    mesh = _moved(Mesh(body.vertices[:, [2, 0, 1]], body.faces), (2.0, 0.0, 0.4), (1.2, 0.5, 0.3))
    # 4 time units (measure's path) x 1.5 = 6: the body (x in [0.8, 3.2]) ends at [6.8, 9.2].
    return mesh, lat, P, animate.PathOffset(lat, "x", speed=1.5, wrap=False)


class OneOfMany:
    """Part 0 moved by ``offset0(t)`` ((3,)), the other parts still (``offset``: (K, 3),
    one row per part, as ``set_rest_offsets`` takes them with parts)."""
    per_part = True

    def __init__(self, offset0, vertex_parts):
        self.offset0, self.parts = offset0, np.asarray(vertex_parts)
        self.count = int(self.parts.max()) + 1

    def offset(self, t):
        O = np.zeros((self.count, 3))
        O[0] = self.offset0(t)
        return O

    def positions(self, V, t):
        X = np.array(V, dtype=np.float64)
        X[self.parts == 0] += self.offset0(t)
        return X


def drag():
    mesh, lat, P, path = whales()
    per_fish = mesh.n_vertices // 4  # the fish are concatenated, one component each
    # Back and forth in its gap (0.6 of the ring between whales; cells 0.36 long), up
    # and down: it crosses cells every frame and never meets the others.
    return mesh, lat, P, OneOfMany(lambda t: [0.25 * np.sin(0.5 * np.pi * t), 0.0, 0.05 * np.sin(np.pi * t)],
                                   np.arange(mesh.n_vertices) // per_fish)


def sphere():
    mesh = shapes.icosphere(7)
    lat = vpffd.Lattice((-1.6, -1.6, -1.6), (1.6, 1.6, 1.6), shape=(8, 8, 8), degree=3)
    P = edits.twist(lat.control_points, 60)
    # 0.5 units in 4 s along a diagonal: the sphere stays inside the box, and its
    # vertices cross cell faces every frame (the processing order changes).
    return mesh, lat, P, animate.PathOffset(lat, (1.0, -0.6, 0.3), speed=0.125)


Mesh = vpffd.Mesh
SCENES = {"whales": whales, "ants": ants, "car": car, "car-open": car_open, "sphere": sphere, "drag": drag}


def measure(mesh, lat, P, path, backend, threads, frames, preserve, move="positions"):
    """(move, frame, fps, device part, host part) medians in ms (fps: of both). `move`:
    "positions" (set_rest_vertices(X + o(t))) or "offsets" (set_rest_offsets(o(t)):
    every object by the path's offset, from the rest mesh of construction; a path with
    ``per_part`` (OneOfMany) gives one offset per part, and the Deformer has parts on
    plain frames too)."""
    # Every object keeps its own volume, on every backend.
    kw = dict(backend=backend)
    if backend != "vulkan":
        kw["threads"] = threads
    if preserve or getattr(path, "per_part", False):
        kw["parts"] = "components"
    d = vpffd.Deformer(mesh, lat, **kw)
    times = np.linspace(0.0, 4.0, frames + 1)
    if move == "offsets":
        inputs = [path.offset(t) for t in times]
        set_rest = d.set_rest_offsets
    elif move == "positions":
        inputs = [path.positions(mesh.vertices, t) for t in times]
        set_rest = d.set_rest_vertices
    else:
        raise ValueError(f"move: 'positions' or 'offsets', got {move!r}")
    set_rest(inputs[0])
    d.deform(P, preserve_volume=preserve)  # warm-up
    if backend == "vulkan":
        run_for(lambda: d.deform(P, preserve_volume=preserve), 1.0)  # the GPU's clock up
    emb, frm, dev, host = [], [], [], []
    for X in inputs[1:]:
        t0 = time.perf_counter()
        set_rest(X)
        t1 = time.perf_counter()
        d.deform(P, preserve_volume=preserve)
        t2 = time.perf_counter()
        # The device's share of the move ran inside the frame's submission.
        g = 1e-3 * d.last_timings()["gpu_move_ms"] if backend == "vulkan" else 0.0
        emb.append(t1 - t0 + g)
        frm.append(t2 - t1 - g)
        dev.append(g)
        host.append(t1 - t0)
    e, f = 1e3 * np.median(emb), 1e3 * np.median(frm)
    return e, f, 1e3 / (e + f), 1e3 * np.median(dev), 1e3 * np.median(host)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--scenes", nargs="*", default=list(SCENES), choices=list(SCENES))
    ap.add_argument("--backends", nargs="*", default=None, help="default: serial, openmp (1 and 2 threads), "
                    "and vulkan when available")
    ap.add_argument("--moves", nargs="*", default=["positions", "offsets"], choices=["positions", "offsets"],
                    help="how the rest mesh moves: set_rest_vertices (positions) and/or set_rest_offsets")
    ap.add_argument("--md", help="also write the table as Markdown to this file")
    a = ap.parse_args()
    avail = vpffd.available_backends()
    backends = a.backends or [b for b in ("serial", "openmp", "vulkan") if b in avail]
    runs = []
    for b in backends:
        if b == "openmp":
            runs += [(b, 1), (b, 2)]
        else:
            runs.append((b, None))
    dev = ""
    if "vulkan" in backends:
        devs = vpffd.vulkan_devices()
        dev = f"; Vulkan device: {devs[0]['name'] if devs else 'none'}"
    head = (f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
            f"load average at start {os.getloadavg()[0]:.2f}{dev}; {a.frames} frames, medians")
    print(head)
    rows = ["| scene | vertices | backend | threads | moved by | move rest mesh (ms) | of which on the device | "
            "of which on the host | plain frame (ms) | plain fps | volume-kept frame (ms) | volume-kept fps | "
            "move / plain frame | move / volume-kept frame | host part / volume-kept frame |",
            "|---|---:|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    # Every CPU row before the first Vulkan one: lavapipe's worker threads outlive its
    # frames and took CPU time from the 2-thread rows measured after them (a 163,842-vertex
    # volume-kept frame on 2 threads: 14.6 ms measured after Vulkan rows, 8.7 ms before).
    scenes = {name: SCENES[name]() for name in a.scenes}
    table = {}
    for b, th in runs:
        for name, how in ((name, how) for name in a.scenes for how in a.moves):
            mesh, lat, P, path = scenes[name]
            try:
                e, fp, fps_p, g, h = measure(mesh, lat, P, path, b, th, a.frames, False, how)
                e2, fk, fps_k, g2, h2 = measure(mesh, lat, P, path, b, th, a.frames, True, how)
            except (vpffd.BackendUnavailableError, vpffd.InvalidInputError) as err:
                print(f"{name} {b}: skipped ({err})")
                continue
            move = np.median([e, e2])
            on_dev = f"{np.median([g, g2]):.2f}" if b == "vulkan" else "-"
            # The host's part of a move (set_rest_vertices itself; on the CPU the whole move):
            # on Vulkan what a GPU cannot hide.
            on_host = np.median([h, h2])
            row = (f"| {name} | {mesh.n_vertices:,} | {b} | {th or '-'} | {how} | {move:.2f} | {on_dev} | "
                   f"{on_host:.2f} | {fp:.1f} | {fps_p:.1f} | {fk:.1f} | {fps_k:.1f} | {move / fp:.2f} | "
                   f"{move / fk:.2f} | {on_host / fk:.2f} |")
            table[name, b, th, how] = row
            print(row, flush=True)
    rows += [table[key] for key in ((name, b, th, how) for name in a.scenes for b, th in runs for how in a.moves)
             if key in table]
    print(f"load average at end {os.getloadavg()[0]:.2f}")
    if a.md:
        with open_replacing(a.md, "w") as fh:
            fh.write(head + "\n\n" + "\n".join(rows) + f"\n\nload average at end {os.getloadavg()[0]:.2f}\n")


if __name__ == "__main__":
    main()
