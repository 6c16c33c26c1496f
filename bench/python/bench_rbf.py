#!/usr/bin/env python
"""Benchmark of the multiresolution RBF deformer (Marinov et al. §6).

    .venv/bin/python bench/python/bench_rbf.py [--subdivisions 5] [--repeats 7] [--handles 10 40 100 400 1000]

On a bumpy icosphere (subdivisions 5: 10,242 vertices), median frame times of
  * regions mode (``RBFDeformer(mr, deformable=, handle_regions=)``): one handle
    region (a cap of n vertices) moved by an affine map, the deformation basis
    precomputed per free vertex; its precompute time (factorisation, K*4 solves,
    basis at every free vertex) beside,
  * general mode (``RBFDeformer(mr, handles).deform(targets)``) of the same
    constraint points and targets: back-substitution, one blocked pass over the foot
    points (values and Jacobians) and one over the base vertices (values),
  * scipy's ``RBFInterpolator(kernel="cubic", degree=1)`` fit and evaluation of the
    base positions alone (the same interpolant; no Jacobians, no reconstruction),
for n handle vertices (spacing=0: every handle vertex is a constraint; H adds the
fixed rings). The regions
frame should be flat in n; the general frame grows as V * H. Then the two
general cases, 40 and 400 handles spread over the mesh, against scipy. Threads: the
vpffd frames on 1 and on all threads; scipy as it runs (its BLAS decides). The load
average is printed: the figures are ratios within one run on one machine.
"""
import argparse
import os
import time

import numpy as np

import vpffd
from vpffd.cli.benchmark import median_ms


def scipy_positions(H, T, X):
    from scipy.interpolate import RBFInterpolator
    return RBFInterpolator(H, T, kernel="cubic", degree=1)(X)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--subdivisions", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--handles", type=int, nargs="+", default=[10, 40, 100, 400, 1000])
    ap.add_argument("--no-scipy", action="store_true")
    a = ap.parse_args()
    mesh = vpffd.shapes.bumpy_sphere(a.subdivisions)
    V = mesh.vertices
    t0 = time.perf_counter()
    mr = vpffd.Multires(mesh, smoothing=10)
    print(f"# RBF multiresolution frames: {mesh.n_vertices} vertices, {mesh.n_faces} triangles "
          f"(decomposition {time.perf_counter() - t0:.2f} s); cpus {os.cpu_count()}, "
          f"OpenMP {vpffd._core.has_openmp()}, load average {os.getloadavg()[0]:.2f}")
    all_threads = vpffd._core.max_threads() if hasattr(vpffd._core, "max_threads") else os.cpu_count()
    deformable = V[:, 2] > -0.3
    order = np.argsort(-V[:, 2])
    T = np.eye(4)
    c, s = np.cos(0.4), np.sin(0.4)
    T[:3, :3] = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    T[:3, 3] = [0.2, 0.0, 0.3]
    print("\n## Regions mode (one handle region, affine map) vs general mode vs scipy, per handle count\n")
    print("| handle vertices | constraints H | free vertices | precompute ms | regions frame ms (1 thr) | "
          "regions frame ms (all) | general frame ms (1 thr) | general frame ms (all) | scipy positions ms |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for n in a.handles:
        idx = order[:n]
        t0 = time.perf_counter()
        rd = vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=[idx], spacing=0)
        pre = 1e3 * (time.perf_counter() - t0)
        rd1 = vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=[idx], spacing=0, threads=1)
        reg1 = median_ms(lambda: rd1.deform(transforms=T), a.repeats)
        reg = median_ms(lambda: rd.deform(transforms=T), a.repeats)
        H, tg = rd.handles, rd.targets(T)
        g = vpffd.RBFDeformer(mr, H)
        g1 = vpffd.RBFDeformer(mr, H, threads=1)
        gen1 = median_ms(lambda: g1.deform(tg), a.repeats)
        gen = median_ms(lambda: g.deform(tg), a.repeats)
        sp = float("nan") if a.no_scipy else median_ms(lambda: scipy_positions(H, tg, mr.base.vertices), a.repeats)
        print(f"| {n} | {len(H)} | {int((rd.labels == 0).sum())} | {pre:.1f} | {reg1:.2f} | {reg:.2f} | "
              f"{gen1:.2f} | {gen:.2f} | {sp:.2f} |")
    print(f"\n## General mode vs scipy (handles spread over the mesh; threads: all = {all_threads})\n")
    print("| handles | general frame ms (1 thr) | general frame ms (all) | scipy positions ms | "
          "general / scipy (all) |")
    print("|---:|---:|---:|---:|---:|")
    rng = np.random.default_rng(0)
    for h in (40, 400):
        H = V[np.linspace(0, len(V) - 1, h).astype(int)]
        tg = H + 0.05 * rng.standard_normal(H.shape)
        g1 = vpffd.RBFDeformer(mr, H, threads=1)
        g = vpffd.RBFDeformer(mr, H)
        gen1 = median_ms(lambda: g1.deform(tg), a.repeats)
        gen = median_ms(lambda: g.deform(tg), a.repeats)
        sp = float("nan") if a.no_scipy else median_ms(lambda: scipy_positions(H, tg, mr.base.vertices), a.repeats)
        print(f"| {h} | {gen1:.2f} | {gen:.2f} | {sp:.2f} | {gen / sp:.2f} |")
    print(f"\nload average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
