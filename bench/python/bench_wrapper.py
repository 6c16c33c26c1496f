#!/usr/bin/env python
"""What the Python layer adds to a frame: ``Deformer.deform`` and ``Deformer.ffd`` with
the core's call replaced by one that returns a result computed beforehand, so that only
the wrapper runs (argument checks, options, the result object), against the same calls
through the core. On small meshes the wrapper is a visible part of a frame (where
vpffd is compared with Blender's modifier).

    .venv/bin/python bench/python/bench_wrapper.py [--calls 2000] [--repeats 9]

Prints microseconds per call (best of --repeats batches of --calls, one process: the
wrapper's time is interpreter work, and the best batch is the least disturbed one) and
the load average.
"""
import argparse
import os
import timeit


import vpffd


class _Answered:
    """The core Deformer with deform/ffd answering from a stored result."""

    def __init__(self, core, frame, ffd):
        self._core, self._frame, self._ffd = core, frame, ffd

    def __getattr__(self, name):
        return getattr(self._core, name)

    def deform(self, P, opts):
        return self._frame

    def ffd(self, P, threads):
        return self._ffd


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--calls", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=9)
    a = ap.parse_args()
    print(f"load average at start {os.getloadavg()[0]:.2f}")
    print("| mesh | vertices | deform: core call (us) | deform: wrapper alone (us) | "
          "ffd: core call (us) | ffd: wrapper alone (us) |")
    print("|---|---:|---:|---:|---:|---:|")
    for level in (3, 4, 5):
        mesh = vpffd.shapes.icosphere(level)
        lat = vpffd.Lattice.around(mesh, shape=(10, 10, 10), degree=3, padding=0.05)
        P = vpffd.edits.twist(lat.control_points, 90)
        d = vpffd.Deformer(mesh, lat, backend="serial")
        core = d._core
        Pc = d._P(P)
        opts = vpffd._core.CorrectionOptions(threads=1)

        def best(stmt):
            t = timeit.repeat(stmt, number=a.calls, repeat=a.repeats)
            return 1e6 * min(t) / a.calls

        core_deform = best(lambda: core.deform(Pc, opts))
        core_ffd = best(lambda: core.ffd(Pc, 1))
        d._core = _Answered(core, core.deform(Pc, opts), core.ffd(Pc, 1))
        wrap_deform = best(lambda: d.deform(P))
        wrap_ffd = best(lambda: d.ffd(P))
        d._core = core
        print(f"| icosphere({level}) | {mesh.n_vertices:,} | {core_deform:.1f} | {wrap_deform:.1f} | "
              f"{core_ffd:.1f} | {wrap_ffd:.1f} |", flush=True)
    print(f"load average at end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
