#!/usr/bin/env python
"""What a frame's output array costs: a fresh array every call, the deformer's reused
one (a frame without out= writes into the array of an earlier frame that nobody
holds), and the caller's own (out=).

    .venv/bin/python bench/python/bench_out.py [--subdivisions 9] [--repeats 7] [--md out.md]

The icosphere of ``--subdivisions`` (9: 2,621,442 vertices, a 63 MB output) in an
8^3 cubic lattice; plain FFD (Deformer.ffd) and a volume-kept xyz frame
(Deformer.deform), on 1 and 2 threads. "fresh" forgets the reusable array before
each call, as every frame did before reuse. Medians (and ranges) of ``--repeats``
calls in ns per vertex, alternated; the load average and CPU are printed. Compare
only figures from one run.
"""
import argparse
import os
import time

import numpy as np

import vpffd
from vpffd._files import open_replacing  # checked writes: a failure leaves the old file
from vpffd._spare import Spares
from vpffd import edits, shapes
from vpffd.cli.benchmark import cpu_model


def measure(subdivisions: int, repeats: int):
    mesh = shapes.icosphere(subdivisions)
    lat = vpffd.Lattice.around(mesh, shape=(8, 8, 8), degree=3, padding=0.05)
    P = edits.squash(lat.control_points, 0.8)
    n = mesh.n_vertices
    rows = []
    threads = [1, 2] if vpffd._core.has_openmp() and (os.cpu_count() or 1) > 1 else [1]
    for th in threads:
        d = vpffd.Deformer(mesh, lat, backend="serial" if th == 1 else "openmp", threads=th)
        out = np.empty((n, 3))
        for frame in ("ffd", "deform"):
            call = d.ffd if frame == "ffd" else d.deform
            t = {k: [] for k in ("fresh", "reused", "out")}
            for _ in range(repeats):
                for kind in t:
                    if kind == "fresh":
                        d._spares = Spares()
                    t0 = time.perf_counter()
                    call(P, out=out) if kind == "out" else call(P)
                    t[kind].append((time.perf_counter() - t0) * 1e9 / n)
            rows.append(dict(threads=th, frame=frame, **{k: (float(np.median(v)), min(v), max(v))
                                                          for k, v in t.items()}))
    return n, rows


def table(n, rows) -> str:
    lines = [f"{n:,} vertices, ns per vertex, median (range)", "",
             "| threads | frame | fresh array | reused array | out= | fresh / reused |", "|---|---|---|---|---|---|"]
    for r in rows:
        cell = lambda k: f"{r[k][0]:.2f} ({r[k][1]:.2f}-{r[k][2]:.2f})"  # noqa: E731
        lines.append(f"| {r['threads']} | {r['frame']} | {cell('fresh')} | {cell('reused')} | {cell('out')} | "
                     f"{r['fresh'][0] / r['reused'][0]:.2f} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--subdivisions", type=int, default=9)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--md", help="also write the table as Markdown")
    a = ap.parse_args(argv)
    n, rows = measure(a.subdivisions, a.repeats)
    head = (f"bench_out: {cpu_model()}, {os.cpu_count()} cores, "
            f"load average {os.getloadavg()[0]:.2f}")
    text = head + "\n\n" + table(n, rows)
    print(text)
    if a.md:
        with open_replacing(a.md, "w") as fh:
            fh.write(text + "\n")
    return rows


if __name__ == "__main__":
    main()
