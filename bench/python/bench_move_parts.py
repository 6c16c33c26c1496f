#!/usr/bin/env python
"""The cost of moving some objects among still ones (Deformer::move_parts).

    .venv/bin/python bench/python/bench_move_parts.py [--fish 16] [--frames 30] [--md out.md]

A shoal of ``--fish`` whales (``shapes.fish(218, 130)``, 28,212 vertices each) on the
demo's ring lattice, ``parts="components"``. Each frame the first 1, 4 or all of them
swim along x by 0.5 sin(0.1 i) (the others keep their place), the rest mesh moved by
``set_rest_offsets`` or by ``set_rest_vertices``, then a volume-kept frame. Where at
most half of the vertices move, only the moving whales are embedded again.

"whole move forced" (offsets only): the still whales' y offsets flip between +0.0 and
-0.0 every frame: the same positions in other bits, so every part counts as moved and
the move takes the whole path: the ratio
of the two rows, measured in the same run, is what moving only some parts saves.
Medians over ``--frames`` frames, on 1 and 2 threads (OpenMP); the load average is
printed. Compare only figures from one run.
"""
import argparse
import os
import platform
import time

import numpy as np

import vpffd
from vpffd._files import open_replacing  # checked writes: a failure leaves the old file
from vpffd import shapes
from vpffd.cli import motion


def measure(scene, n_moving, threads, frames, move="offsets", force_whole=False):
    """(move ms, volume-kept frame ms), medians: the first ``n_moving`` parts swim."""
    d = vpffd.Deformer(scene.mesh, scene.lattice, backend="openmp", threads=threads, parts="components")
    K = d.n_parts
    labels = d.vertex_parts  # part of every vertex (rows of set_rest_offsets)
    O = np.zeros((K, 3))
    V = scene.mesh.vertices
    d.set_rest_offsets(O) if move == "offsets" else d.set_rest_vertices(V)
    d.deform(scene.control_points)
    moves, frame_times = [], []
    for i in range(frames):
        O = O.copy()
        O[:n_moving, 0] = 0.5 * np.sin(0.1 * i)
        if force_whole:
            O[n_moving:, 1] = 0.0 if i % 2 else -0.0
        X = V + O[labels] if move == "positions" else None
        t0 = time.perf_counter()
        if move == "offsets":
            d.set_rest_offsets(O)
        else:
            d.set_rest_vertices(X)
        t1 = time.perf_counter()
        d.deform(scene.control_points)
        t2 = time.perf_counter()
        moves.append(t1 - t0)
        frame_times.append(t2 - t1)
    return 1e3 * np.median(moves), 1e3 * np.median(frame_times)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fish", type=int, default=16)
    ap.add_argument("--fish-size", type=int, nargs=2, default=(218, 130), help="shapes.fish's two counts")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--md", help="also write the table as Markdown to this file")
    a = ap.parse_args(argv)
    scene = motion.shoal(n_fish=a.fish, fish=shapes.fish(*a.fish_size))
    head = (f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, load average at "
            f"start {os.getloadavg()[0]:.2f}; {a.fish} whales, {scene.mesh.n_vertices:,} vertices; medians of "
            f"{a.frames} frames")
    print(head)
    rows = ["| threads | moved by | whales moving | move (ms) | volume-kept frame (ms) | move / frame |",
            "|---:|---|---|---:|---:|---:|"]
    threads = (1, 2) if vpffd._core.has_openmp() else (1,)
    counts = sorted({1, min(4, a.fish), a.fish})
    for th in threads:
        for move in ("offsets", "positions"):
            cases = [(k, False) for k in counts]
            if move == "offsets" and a.fish > 1:
                cases.insert(1, (1, True))
            for k, whole in cases:
                m, f = measure(scene, k, th, a.frames, move, whole)
                label = f"{k} of {a.fish}" + (", whole move forced" if whole else "")
                rows.append(f"| {th} | {move} | {label} | {m:.2f} | {f:.2f} | {m / f:.2f} |")
                print(rows[-1], flush=True)
    tail = f"load average at end {os.getloadavg()[0]:.2f}"
    print(tail)
    if a.md:
        with open_replacing(a.md, "w") as fh:
            fh.write(head + "\n\n" + "\n".join(rows) + "\n\n" + tail + "\n")


if __name__ == "__main__":
    main()
