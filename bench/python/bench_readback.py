#!/usr/bin/env python3
"""How a Vulkan frame's vertices reach the caller: the caller's order made on the device
(the default) against the device's order reordered on the host
(VPFFD_VULKAN_READBACK=host), one process, frames of both interleaved so that both see
the same load.

    .venv/bin/python bench/python/bench_readback.py [--subdiv 9] [--repeats 5] [--precision auto]
        [--frames plain,xyz] [--md bench/results/<machine>/readback_<machine>.md]

Per frame kind (plain FFD, volume-preserving xyz) and read back (device, host) and
with or without out=: medians of the Python call, the device's frame (gpu_total_ms)
and read back (gpu_readback_ms), the host's stages, and the host's share: the
Python call less the device's frame and read back, in ns per vertex. Beside each
end-to-end time its ratio to the memory floor (_floor.py: the float64 result written
once at this run's copy bandwidth). On lavapipe (Mesa's CPU driver) the device's
columns are CPU work too: only the host columns say what a GPU machine's host does.
"""
import argparse
import os
import platform
import statistics
import sys
from pathlib import Path

import numpy as np

import vpffd
from vpffd.cli.benchmark import frame_edit, load_average

import _floor  # bench/python: the memory floor of a frame


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--subdiv", type=int, default=9, help="icosphere subdivision (9: 2,621,442 vertices)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--precision", default="auto", choices=["auto", "float64", "float-float"])
    ap.add_argument("--frames", default="plain", help="comma-separated: plain, xyz")
    ap.add_argument("--md", default=None, help="also write the table to this markdown file")
    a = ap.parse_args()
    mesh = vpffd.shapes.icosphere(a.subdiv)
    nv = mesh.n_vertices
    lat = vpffd.Lattice.around(mesh, shape=10)
    P = frame_edit(lat)
    load_start = load_average()
    bw = _floor.copy_bandwidth()
    floor = _floor.floor_ms(nv, bw)
    ds = {}
    for where in ("device", "host"):
        os.environ["VPFFD_VULKAN_READBACK"] = where
        try:
            ds[where] = vpffd.Deformer(mesh, lat, backend="vulkan", gpu_precision=a.precision)
        finally:
            del os.environ["VPFFD_VULKAN_READBACK"]
    dev = ds["device"]
    out = np.empty((nv, 3))
    lines = [f"{nv:,} vertices (icosphere({a.subdiv})) on {dev.device['name']} ({dev.gpu_precision} sums), "
             f"{platform.node()}, {os.cpu_count()} cores; medians of {a.repeats}; load average {load_start} at the "
             "start", "",
             "| frame | read back | out= | Python call ms | device frame ms | device read back ms | "
             "host unpack ms | host share ms | host ns / vertex | call / floor |",
             "|---|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for kind in a.frames.split(","):
        kw = dict(preserve_volume=False) if kind == "plain" else {}
        for d in ds.values():  # shader compilation, first touch
            d.deform(P, **kw)
            d.deform(P, out=out, **kw)
        runs = {(w, o): [] for w in ds for o in (False, True)}
        for _ in range(a.repeats):
            for w, d in ds.items():
                r = d.deform(P, **kw)
                del r  # let go of the result, as a frame loop does
                runs[w, False].append(d.last_timings())
                d.deform(P, out=out, **kw)
                runs[w, True].append(d.last_timings())
        for (w, o), T in runs.items():
            med = lambda k: statistics.median(t[k] for t in T)  # noqa: E731
            share = statistics.median(t["python_total_ms"] - t["gpu_total_ms"] - t["gpu_readback_ms"] for t in T)
            lines.append(f"| {kind} | {w} | {'yes' if o else 'no'} | {med('python_total_ms'):.2f} | "
                         f"{med('gpu_total_ms'):.2f} | {med('gpu_readback_ms'):.2f} | {med('host_unpack_ms'):.2f} | "
                         f"{share:.2f} | {share * 1e6 / nv:.2f} | {med('python_total_ms') / floor:.1f} |")
    lines += ["", _floor.note(bw) + f" (floor {floor:.2f} ms)", f"load average at the end {load_average()}",
              "host share: the Python call less the device's frame and read back (timestamps)"]
    text = "\n".join(lines)
    print(text)
    if a.md:
        Path(a.md).parent.mkdir(parents=True, exist_ok=True)
        Path(a.md).write_text(text + "\n")


if __name__ == "__main__":
    sys.exit(main())
