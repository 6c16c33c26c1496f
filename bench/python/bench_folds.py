#!/usr/bin/env python
"""Fold-check benchmark: time of ``vpffd.check_folds`` for 6^3, 10^3
and 16^3 cubic lattices on a twist and on a random edit, and how many cells
needed subdivision.

    .venv/bin/python bench/python/bench_folds.py [--repeats 9] [--threads N] [--out FILE]

Prints a markdown table (medians of --repeats runs in one process) with the
machine and its load average, and writes it as JSON (default
bench/results/<machine>/folds_<machine>.json; machine: $VPFFD_BENCH_MACHINE, else the host name).
"""
import argparse
import json
import os
import platform
from pathlib import Path

import numpy as np

import vpffd
from vpffd._files import write_text  # checked writes: a failure leaves the old file
from vpffd.cli.benchmark import median_ms


def edits(lat):
    """(name, control points): a 90 deg twist, a 300 deg twist and two random edits
    (each control point coordinate moved by N(0, s cell)); verdicts as they come."""
    n = lat.shape[0]
    rng = np.random.default_rng(1)
    cell = (lat.box_max - lat.box_min) / (n - 3)
    return [
        ("twist 90", vpffd.twist(lat.rest_points, 90)),
        ("twist 300", vpffd.twist(lat.rest_points, 300)),
        ("random 0.03 cell", lat.rest_points + rng.normal(0, 0.03, lat.rest_points.shape) * cell),
        ("random 0.3 cell", lat.rest_points + rng.normal(0, 0.3, lat.rest_points.shape) * cell),
    ]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--threads", type=int, default=None, help="OpenMP threads (default all)")
    ap.add_argument("--depth", type=int, default=vpffd.folds.DEFAULT_DEPTH)
    machine = os.environ.get("VPFFD_BENCH_MACHINE") or platform.node() or "host"
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "results" / machine /
                                         f"folds_{machine}.json"))
    a = ap.parse_args()
    rows = []
    load = os.getloadavg()
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"OpenMP threads {a.threads or vpffd._core.max_threads()}, load average {load[0]:.2f} {load[1]:.2f} "
          f"{load[2]:.2f}; medians of {a.repeats} runs, depth {a.depth}")
    print("| lattice | cells | edit | verdict | refined cells | subcells | median ms | us per cell |")
    print("|---|---|---|---|---|---|---|---|")
    for n in (6, 10, 16):
        lat = vpffd.Lattice([0, 0, 0], [1, 1, 1], shape=n, degree=3)
        for name, P in edits(lat):
            rep = vpffd.check_folds(lat, P, depth=a.depth, threads=a.threads)
            ms = median_ms(lambda: vpffd.check_folds(lat, P, depth=a.depth, threads=a.threads), a.repeats)
            verdict = "certified" if rep.certified else ("folded" if rep.folded else "unknown")
            rows.append(dict(shape=n, cells=rep.n_cells, edit=name, verdict=verdict, refined=rep.n_refined,
                             subcells=rep.n_subcells, unknown=rep.n_unknown, folded_cells=rep.n_folded,
                             median_ms=ms, us_per_cell=1e3 * ms / rep.n_cells))
            print(f"| {n}^3 cubic | {rep.n_cells} | {name} | {verdict} | {rep.n_refined} | {rep.n_subcells} | "
                  f"{ms:.2f} | {1e3 * ms / rep.n_cells:.1f} |")
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)  # a new machine's folder
    out.parent.mkdir(parents=True, exist_ok=True)
    write_text(out, json.dumps(dict(machine=platform.processor() or platform.machine(), cores=os.cpu_count(),
                                   threads=a.threads or vpffd._core.max_threads(), load_average=load,
                                   repeats=a.repeats, depth=a.depth, rows=rows), indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
