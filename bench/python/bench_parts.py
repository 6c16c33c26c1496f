#!/usr/bin/env python
"""Cost of moving the rest mesh and of keeping several parts' volumes.

    .venv/bin/python bench/python/bench_parts.py [--repeats 9] [--subdiv 5] [--threads N]

1. ``set_rest_vertices`` against an xyz frame on the same Deformer (a box mesh of
   ~100k vertices, the benchmarks' frame edit), rounds alternating between the two
   so that a change in load hits both.
2. An xyz frame with K parts (K spheres of one mesh) against the same mesh without
   parts, for K = 2, 8, 32, 128 (same rounds alternating).
Prints medians in ms, the ratios and the load average before and after; nothing is
asserted (speed belongs here, not in the tests).
"""
import argparse
import os
import time

import numpy as np

import vpffd
from vpffd import edits, shapes
from vpffd.benchmark import frame_edit


def alternating_medians(fns, repeats):
    """Median ms of each of ``fns``, called in turn `repeats` times after a warm-up."""
    for f in fns:
        f()
    times = [[] for _ in fns]
    for _ in range(repeats):
        for i, f in enumerate(fns):
            s = time.perf_counter()
            f()
            times[i].append(1e3 * (time.perf_counter() - s))
    return [float(np.median(t)) for t in times]


def spheres(count, subdiv):
    s = shapes.icosphere(subdiv)
    side = int(np.ceil(count ** (1 / 3)))
    centres = [(3.0 * (i % side), 3.0 * (i // side % side), 3.0 * (i // side // side)) for i in range(count)]
    V = np.concatenate([s.vertices + c for c in centres])
    F = np.concatenate([s.faces + i * s.n_vertices for i in range(count)])
    return vpffd.Mesh(V, F)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--box", type=int, default=129, help="box mesh side: 6 n^2 + 2 vertices (129: 99,848)")
    a = ap.parse_args()
    backend = "openmp" if vpffd._core.has_openmp() else "serial"
    print(f"load average before: {os.getloadavg()}")

    mesh = shapes.box(a.box)
    lat = vpffd.Lattice.around(mesh, shape=(10, 10, 10), padding=0.3)
    d = vpffd.Deformer(mesh, lat, backend=backend, threads=a.threads)
    P = frame_edit(lat)
    X = [mesh.vertices + [0.01 * i, -0.02 * i, 0.005 * i] for i in range(2)]
    k = [0]

    def move():
        k[0] ^= 1
        d.set_rest_vertices(X[k[0]])

    frame, moving = alternating_medians([lambda: d.deform(P), move], a.repeats)
    print(f"\n{mesh.n_vertices:,} vertices, 10^3 cubic lattice, {backend}:")
    print(f"  xyz frame          {frame:8.2f} ms")
    print(f"  set_rest_vertices  {moving:8.2f} ms   ({moving / frame:.2f} of a frame)")

    print("\nxyz frame with K parts (K spheres) against the same mesh without parts:")
    print("   K  vertices    no parts      parts   ratio")
    for K, subdiv in ((2, 5), (8, 4), (32, 3), (128, 2)):
        m = spheres(K, subdiv)
        lk = vpffd.Lattice.around(m, shape=(10, 10, 10))
        whole = vpffd.Deformer(m, lk, backend=backend, threads=a.threads)
        parts = vpffd.Deformer(m, lk, backend=backend, threads=a.threads, parts="components")
        Pk = edits.twist(edits.squash(lk.control_points, 0.6), 90)
        t0, t1 = alternating_medians([lambda: whole.deform(Pk), lambda: parts.deform(Pk)], a.repeats)
        print(f"{K:4d} {m.n_vertices:9,d} {t0:9.2f} ms {t1:8.2f} ms {t1 / t0:7.2f}")
    print(f"\nload average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
