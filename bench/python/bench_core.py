#!/usr/bin/env python
"""CPU benchmark of the volume-preserving frame (the README's CPU table).

    .venv/bin/python bench/python/bench_core.py [--repeats 7] [--no-shared] [--no-csr]

Prints a markdown table (medians of --repeats runs, one process, one run), then
where an xyz frame's time goes (FFD, coefficient passes, solves, gathers, volume,
reordering: the frame's own per-pass clocks, medians) with the load average, what
the options normals=True, weights="auto" and on_fold="warn" add to a frame, and
each frame time against its memory floor (the caller's float64 vertices written once at
this run's copy bandwidth, _floor.py), and
writes bench/results/<machine>/cpu_<machine>.json (machine: $VPFFD_BENCH_MACHINE, else
the host name). For the side-by-side comparison with
Blender's Lattice modifier see bench_peers.py. The meshes of ../shared/data/meshes are
used when present; the icospheres are generated in code.
"""
import argparse
import os
import platform
from pathlib import Path

from vpffd.cli.benchmark import load_average, run_benchmark

import _floor  # bench/python: the memory floor of a frame


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--no-shared", action="store_true", help="only the generated meshes")
    ap.add_argument("--no-csr", action="store_true", help="skip the paper's matrix (it needs ~1.4 GB for the dragon)")
    machine = os.environ.get("VPFFD_BENCH_MACHINE") or platform.node() or "host"
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "results" / machine /
                                         f"cpu_{machine}.json"))
    a = ap.parse_args()
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)  # a new machine's folder
    bandwidth = _floor.copy_bandwidth()
    rows = run_benchmark(include_shared=not a.no_shared, repeats=a.repeats, with_csr=not a.no_csr, out=a.out)
    print_floors(rows, bandwidth)


def print_floors(rows, bandwidth):
    """Each frame time of the table beside its ratio to the frame's memory floor (_floor.py)."""
    print(f"\nFrame times against the memory floor (ms, and time / floor; load average {load_average()})")
    print("| mesh | backend | threads | method | floor ms | FFD ms | FFD / floor | 1 axis ms | 1 axis / floor | "
          "xyz frame ms | xyz / floor |")
    print("|" + "---|" * 11)
    for r in rows:
        f = _floor.floor_ms(r["vertices"], bandwidth)
        print(f"| {r['mesh']} | {r['backend']} | {r['threads']} | {r['method']} | {f:.3f} | "
              f"{r['ffd_ms']:.2f} | {r['ffd_ms'] / f:.1f} | {r['one_axis_ms']:.2f} | {r['one_axis_ms'] / f:.1f} | "
              f"{r['xyz_ms']:.2f} | {r['xyz_ms'] / f:.1f} |")
    print(_floor.note(bandwidth))


if __name__ == "__main__":
    main()
