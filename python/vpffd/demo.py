"""The README's main job: plain versus volume-preserving FFD on built-in meshes."""
from __future__ import annotations

import time

import numpy as np

from . import edits, shapes
from .deformer import Deformer
from .lattice import Lattice


def _row(name, rest, r, ms):
    plain = 100 * (r.volume_before - rest) / rest
    kept = 100 * (r.volume - rest) / rest
    print(f"  {name:<34} {plain:+9.2f} %   {kept:+12.2e} %   {ms:8.2f} ms")


def run_demo(quick: bool = False) -> None:
    print("vpffd demo: enclosed volume after a plain FFD and after the volume-preserving one")
    print(f"  {'deformation':<34} {'plain FFD':>11}   {'preserved':>14}   {'frame':>11}")
    cases = []
    ball = shapes.icosphere(4)
    lat = Lattice.around(ball, shape=(6, 6, 6), degree=3, padding=0.05)
    cases.append(("sphere squashed to 40 % height, xy", ball, lat, edits.squash(lat.control_points, 0.4), "xy"))
    cases.append(("sphere squashed to 40 % height, xyz", ball, lat, edits.squash(lat.control_points, 0.4), "xyz"))
    cube = shapes.box(16 if quick else 32)
    clat = Lattice.around(cube, shape=(5, 5, 5), degree=3, padding=0.02)
    for deg in ([180] if quick else [90, 180, 360]):
        cases.append((f"cube twisted {deg} deg, xy only", cube, clat, edits.twist(clat.control_points, deg), "xy"))
    cases.append(("cube twisted 180 deg, z only", cube, clat, edits.twist(clat.control_points, 180), "z"))
    cases.append(("sphere bent 90 deg + tapered", ball, lat,
                  edits.taper(edits.bend(lat.control_points, 90, axis="z", toward="x"), 0.5), "xyz"))
    for name, mesh, L, P, axes in cases:
        d = Deformer(mesh, L)
        d.deform(P, axes=axes)  # warm-up
        t = time.perf_counter()
        r = d.deform(P, axes=axes)
        ms = 1e3 * (time.perf_counter() - t)
        _row(name, d.rest_volume, r, ms)
        assert abs(r.volume - d.rest_volume) <= 1e-10 * abs(d.rest_volume)
    print("(volume change relative to the rest mesh; 'preserved' is the exact correction)")
