#!/usr/bin/env python
"""Time of vpffd.render_comparison, with its parts (the aim: under a second for a
500k-vertex mesh at 1600 x 600 on 2 cores).

    OMP_NUM_THREADS=2 .venv/bin/python bench/python/bench_render.py [--subdiv 8] [--repeats 5]
        [--size 1600x600] [--mesh PATH]

The mesh is the README's pear figure (vpffd._figure) on icosphere(subdiv):
subdiv 8 gives 655,362 vertices and 1,310,720 triangles; --mesh times a closed
mesh file instead (e.g. ../shared/data/meshes' dragon, 435,545 vertices). Prints medians of
--repeats runs and the load average (the machine may be shared).
"""
import argparse
import itertools
import os
import statistics
import time

import numpy as np

import vpffd
from vpffd import comparison
from vpffd._figure import figure


def median_ms(fn, repeats):
    """Medians of the wall time and of the process CPU time (all threads), ms. On
    a shared, loaded machine the CPU time is the steadier figure: with 2 threads
    an unloaded wall time is about CPU / 2 where the work is parallel."""
    ts, cs = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        ts.append(1e3 * (time.perf_counter() - t0))
        cs.append(1e3 * (time.process_time() - c0))
    return statistics.median(ts), statistics.median(cs)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--subdiv", type=int, default=8)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--size", default="1600x600")
    ap.add_argument("--mesh", default=None, metavar="PATH",
                    help="a closed mesh file instead of the figure (e.g. the dragon, 435,545 vertices)")
    a = ap.parse_args()
    w, h = (int(s) for s in a.size.split("x"))
    mesh = vpffd.load_mesh(a.mesh) if a.mesh else figure(a.subdiv)
    lat = vpffd.Lattice.around(mesh, shape=(8, 8, 8))
    d = vpffd.Deformer(mesh, lat, backend="openmp")
    r = d.deform(vpffd.edits.squash(lat.control_points, 0.6, axis="y"), axes="xz")
    plain = r.control_points - r.offsets
    moving = vpffd.Scene(mesh, refit=True)
    frames = itertools.cycle([r.vertices, mesh.vertices])
    panel_cam = comparison.fit_camera(r.vertices, up="y", size=(w // 3, h - 110))
    print(f"mesh: {mesh.n_vertices:,} vertices, {mesh.n_faces:,} triangles; picture {w} x {h}; "
          f"threads {vpffd._core.max_threads()}; load average {os.getloadavg()[0]:.2f} before")
    rows = [
        ("render_comparison, lattice faint, det J colours, samples 2",
         lambda: vpffd.render_comparison(d, r, size=(w, h), up="y")),
        ("render_comparison, lattice none, no colours, samples 1",
         lambda: vpffd.render_comparison(d, r, size=(w, h), up="y", lattice_style="none", color="none",
                                         samples=1)),
        ("  part: plain FFD of the vertices", lambda: d.ffd(plain)),
        ("  part: det J at the vertices (x2 panels)",
         lambda: (comparison.local_volume_change(d, plain), comparison.local_volume_change(d, r.control_points))),
        ("  part: one Embree scene (BVH build, render's fast build)",
         lambda: vpffd._core.RayScene(r.vertices, mesh.faces, True)),
        ("  part: one refittable scene (BVH build, render_comparison's)",
         lambda: vpffd._core.RayScene(mesh.vertices, mesh.faces, False, True)),
        ("  part: refit to a deformed mesh (Scene.set_vertices)", lambda: moving.set_vertices(next(frames))),
        ("  part: the camera framing the 3 panels (fit_camera)",
         lambda: comparison.fit_camera(np.concatenate([mesh.vertices, r.vertices, r.vertices]), up="y",
                                       size=(w // 3, h - 110))),
        ("  part: one panel render (scene + rays, samples 2)",
         lambda: vpffd.render(vpffd.Mesh(r.vertices, mesh.faces), size=(w // 3, h - 110), samples=2,
                              colors=np.full((mesh.n_vertices, 3), 0.8))),
        ("  part: one panel of render_comparison (refit, normals, rays, samples 2)",
         lambda: (moving.set_vertices(next(frames)),
                  vpffd.render(moving, panel_cam, size=(w // 3, h - 110), samples=2,
                               colors=np.full((mesh.n_vertices, 3), 0.8)))),
    ]
    print("| step | wall ms (median) | CPU ms, all threads (median) |\n|---|---:|---:|")
    for name, fn in rows:
        fn()  # warm-up
        wall, cpu = median_ms(fn, a.repeats)
        print(f"| {name} | {wall:.0f} | {cpu:.0f} |")
    print(f"load average {os.getloadavg()[0]:.2f} after")


if __name__ == "__main__":
    main()
