#!/usr/bin/env python
"""Moving the rest mesh from Python: ``Deformer.set_rest_vertices`` as a user calls it
(argument checks, the copy the Deformer keeps, the core's move) against the core's
move alone and ``set_rest_offsets`` (the same two places as offsets), back and forth
between two positions 2 % of the mesh's size apart in a
10^3 cubic lattice (vertices change cell every call: the processing order changes),
on 1 and 2 threads. A move no longer sums the rest volume (a frame that needs it does:
cpp/include/vpffd/frame/rest_volume.h), so it is the move alone. With
``--backend vulkan`` it is the host's part of a move (staging the positions with their
checks): moves in a row with no frame between them leave the device work to the next
frame, which never comes here.

    .venv/bin/python bench/python/bench_move.py [--moves 15] [--mesh PATH] [--level 7] [--backend cpu|vulkan]

Without --mesh: an icosphere of the given level (7: 163,842 vertices). Prints the
median milliseconds per move and the load average. To compare two builds, run it
with each in turn (bench/results/vm/lazy_rest_volume_vm.md).
"""
import argparse
import os
import time

import numpy as np

import vpffd


def median_ms(fn, n):
    t = []
    for i in range(n):
        t0 = time.perf_counter()
        fn(i)
        t.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(t))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--moves", type=int, default=15)
    ap.add_argument("--mesh", help="a mesh file (default: an icosphere)")
    ap.add_argument("--level", type=int, default=7, help="icosphere subdivision level without --mesh")
    ap.add_argument("--backend", choices=("cpu", "vulkan"), default="cpu")
    a = ap.parse_args()
    mesh = vpffd.io.load_mesh(a.mesh) if a.mesh else vpffd.shapes.icosphere(a.level)
    lat = vpffd.Lattice.around(mesh, shape=(10, 10, 10), degree=3, padding=0.1)
    lo, hi = vpffd._arrays.bounds(mesh.vertices)
    step = 0.01 * (hi - lo)
    X = (mesh.vertices + step, mesh.vertices - step)
    print(f"{mesh.n_vertices:,} vertices; load average at start {os.getloadavg()[0]:.2f}")
    O = (step, -step)  # set_rest_offsets to the same two places
    print("| threads | set_rest_vertices (ms) | core move alone (ms) | set_rest_offsets (ms) |")
    print("|---:|---:|---:|---:|")
    if a.backend == "vulkan":
        d = vpffd.Deformer(mesh, lat, backend="vulkan")
        d.set_rest_vertices(X[1])
        d.deform()  # the construction's device work done
        py = median_ms(lambda i: d.set_rest_vertices(X[i % 2]), a.moves)
        core = median_ms(lambda i: d._vk.set_rest_vertices(X[i % 2]), a.moves)
        d.set_rest_vertices(mesh.vertices)  # the base of the offsets
        off = median_ms(lambda i: d.set_rest_offsets(O[i % 2]), a.moves)
        print(f"| {vpffd._core.max_threads()} (host) | {py:.2f} | {core:.2f} | {off:.2f} |")
    backend = "openmp" if vpffd._core.has_openmp() else "serial"
    for threads in ((1, 2) if backend == "openmp" else (1,)) if a.backend == "cpu" else ():
        d = vpffd.Deformer(mesh, lat, backend=backend, threads=threads)
        py = median_ms(lambda i: d.set_rest_vertices(X[i % 2]), a.moves)
        core = median_ms(lambda i: d._core.set_rest_vertices(X[i % 2], threads), a.moves)
        d.set_rest_vertices(mesh.vertices)
        off = median_ms(lambda i: d.set_rest_offsets(O[i % 2]), a.moves)
        print(f"| {threads} | {py:.2f} | {core:.2f} | {off:.2f} |")
    print(f"load average at end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
