#!/usr/bin/env python
"""Benchmark of multiresolution frames (Marinov et al.'s Table II).

    .venv/bin/python bench/python/bench_multires.py [--sizes 6 7 8] [--repeats 5] [--no-shared] [--no-vulkan]
        [--meshes dragon bunny armadillo] [--no-rbf] [--rbf-handles 100] [--no-accuracy]

Per mesh, on the CPU with 1 and 2 threads and on the first suitable Vulkan device
(a "vulkan" row; on a machine without a GPU that is lavapipe, Mesa's CPU driver, so
its figures are not a GPU's), median frame times of
  * plain FFD of the fine mesh (positions only: Deformer.ffd),
  * plain FFD with exact deformed normals (positions + cof(J) n per vertex),
  * the multiresolution reconstruction (FFD and analytic Jacobian at the foot
    point, p' = S' + d N_S', approximate normal of eqs. 6-7; on the CPU the cell-run
    kernel, MultiresFFD.deform, with the per-point kernel's time, deform_per_point,
    printed beside as "MR per-point ms"),
in million triangles per second, and the bytes per vertex each reads; the time of the
decomposition itself (``vpffd.Multires``: fairing, foot points, coefficients) on 1
and 2 threads. On Vulkan the
three are one submission each (VulkanDeformer's plain frame, with its normals
pass, and VulkanMultires), timed end to end on the host (upload, dispatch, read-back
and reordering), with the device's own timestamps of the multiresolution frame
printed beside; the volume-corrected multiresolution frame (MultiresDeformer.deform,
volume "base" and "fine") is one submission (the Deformer's frame, then the
reconstruction from its device buffers), and beside it the same frame as two
submissions with the corrected control points going through the host (the Deformer's
frame, then VulkanMultires of its control points; "fine" adds the base's FFD), the
route before the reconstruction became a tail of the Deformer's submission. Then the
approximate-normal error table (mean / 95th percentile / max angle to the normals
of the deformed fine mesh) for a moderate edit and two extreme ones, at several
smoothing strengths.

The RBF rows (Marinov et al. §6, ``vpffd.RBFDeformer`` in place of the lattice), per mesh on
the same decomposition, threads and device, in a second table beside the plain FFD of
the same row:
  * general mode: ``--rbf-handles`` handle points spread over the mesh (every
    V / H-th vertex) moved by a smooth displacement; a frame is the back-substitution
    and one blocked pass over the foot points (RbfMap.solve + RbfMap.deform: positions
    and normals, as the FFD's multiresolution frame); CPU only (no device frame);
  * regions mode: deformable the 70 % of vertices highest in z, one handle region
    (the top 5 %) moved by one affine map, constraint points thinned to 2 % of the
    diagonal; a frame is
    the O(V K) pass over the precomputed basis (RbfRegions.deform: positions, normals
    and base vertices), on the CPU and, where a device is found, on Vulkan
    (VulkanRbfFrame, one dispatch, timed end to end on the host). Bumpy icospheres are generated in code; the dragon is read
from ../shared/data/meshes when present. The load average is printed: the
figures are ratios within one run on one machine.
"""
import argparse
import os
import time
from pathlib import Path

import numpy as np

import vpffd
from vpffd import _core
from vpffd.cli.benchmark import cpu_model
from vpffd.normals import angles_deg

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "meshes"


def median_ms(f, repeats):
    f()  # warm-up
    t = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        t.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(t))


SCANS = {"bunny": "bunny_watertight.ply", "armadillo": "armadillo.ply", "horse": "horse.ply",
         "dragon": "dragon_vrip_welded.ply.gz"}


def meshes(sizes, shared, scans=("dragon",)):
    for s in sizes:
        yield f"bumpy ico{s}", vpffd.shapes.bumpy_sphere(s)
    for name in scans if shared else ():
        if (SHARED / SCANS[name]).exists():
            yield name, vpffd.load_mesh(SHARED / SCANS[name])


def pull_four(lat, frac=0.2):
    P = lat.control_points.copy()
    ext = lat.box_max - lat.box_min
    nu, nv, nw, _ = P.shape
    for j, k in [(nv // 2 - 1, nw // 2 - 1), (nv // 2, nw // 2 - 1), (nv // 2 - 1, nw // 2), (nv // 2, nw // 2)]:
        P[nu - 2, j, k, 0] += frac * ext[0]
    return P


def vulkan_selector():
    """Index of the first suitable Vulkan device (a string) and its name, or None."""
    ok = [d for d in vpffd.vulkan_devices() if d["suitable"]]
    return (str(ok[0]["index"]), ok[0]["name"]) if ok else None


def speed_vulkan(name, mesh, mr, lat, P, repeats, selector):
    """The Vulkan row: plain FFD, FFD with normals and the multiresolution frame, one
    submission each, and the corrected frames."""
    dv = vpffd.Deformer(mesh, lat, backend="vulkan", device=selector)
    mv = vpffd.MultiresDeformer(mr, lat, backend="vulkan", device=selector)
    plain = _core.CorrectionOptions(preserve_volume=False)
    t_ffd = median_ms(lambda: dv._vk.deform(P, plain), repeats)
    t_ffdn = median_ms(lambda: dv._vk.deform(P, plain, normals=True), repeats)
    gpu = []

    def mr_frame():
        mv._vk.deform(P)
        gpu.append(mv._vk.last_timings()["gpu_total_ms"])
    t_mr = median_ms(mr_frame, repeats)
    t_vol = median_ms(lambda: dv.deform(P), repeats)
    t_mrvol = median_ms(lambda: mv.deform(P, volume="base"), repeats)
    t_mrfine = median_ms(lambda: mv.deform(P, volume="fine"), repeats)
    fine = mv._fine_deformer()

    def two_submissions(volume):
        # The correction, its control points through the host, then the reconstruction
        # (and for "fine" the base's FFD) as separate submissions.
        r = (mv._base if volume == "base" else fine).deform(P)
        Pc = np.ascontiguousarray(r.control_points.reshape(-1, 3))
        if volume == "fine":
            mv._base._vk.deform(Pc, plain)
        mv._vk.deform(Pc)
    t_two = {v: median_ms(lambda v=v: two_submissions(v), repeats) for v in ("base", "fine")}
    mt = mesh.n_faces / 1e6
    row = (name, mesh.n_vertices, mesh.n_faces, "vulkan", t_ffd, t_ffdn, t_mr, t_vol, t_mrvol,
           mt / (t_ffd / 1e3), mt / (t_ffdn / 1e3), mt / (t_mr / 1e3))
    return row, float(np.median(gpu)), {"base": (t_mrvol, t_two["base"]), "fine": (t_mrfine, t_two["fine"])}


def rbf_setting(mesh, n_handles):
    """The RBF rows' edits: (general handles (H, 3), their targets (H, 3), deformable
    mask (V,), handle region indices, one affine 4 x 4 map)."""
    V = mesh.vertices
    diag = float(np.linalg.norm(np.ptp(V, axis=0)))
    H = V[np.linspace(0, len(V) - 1, n_handles).astype(int)]
    c = V.mean(axis=0)
    # A smooth displacement of the handles: a bend-like sway growing with height.
    h = (H[:, 2] - c[2]) / diag
    targets = H + 0.1 * diag * np.stack([h ** 2, 0.5 * h, np.zeros_like(h)], axis=1)
    z = V[:, 2]
    deformable = z > np.quantile(z, 0.3)
    handle = np.flatnonzero(z > np.quantile(z, 0.95))
    a = np.radians(20.0)
    T = np.eye(4)
    T[:3, :3] = [[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]]
    top = V[handle].mean(axis=0)
    T[:3, 3] = top - T[:3, :3] @ top + [0.1 * diag, 0.0, 0.05 * diag]
    return H, targets, deformable, handle, T


def speed_rbf(mr, mesh, n_handles, repeats, vk):
    """The RBF rows of one mesh: [(mode, threads, H, frame ms)] for the general mode
    on 1 and 2 threads and the regions mode on 1 and 2 threads and on Vulkan."""
    H, targets, deformable, handle, T = rbf_setting(mesh, n_handles)
    out = []
    g = vpffd.RBFDeformer(mr, H)
    m = mr._m
    for threads in (1, 2):
        out.append(("RBF general", threads, len(H),
                    median_ms(lambda: g._rbf.deform(m, g._rbf.solve(targets), threads), repeats)))
    # Constraint points 2 % of the diagonal apart: a few hundred on any mesh, so the
    # one-time (H+4)^2 factorisation stays small (the frame does not depend on H).
    diag = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    rd = vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=[handle], spacing=0.02 * diag)
    Ts = [T]
    for threads in (1, 2):
        out.append(("RBF regions", threads, rd.n_handles, median_ms(lambda: rd._regions.deform(Ts, threads),
                                                                    repeats)))
    if vk is not None:
        frame = rd._vulkan_frame(vk[0], None)
        out.append(("RBF regions", "vulkan", rd.n_handles, median_ms(lambda: frame.deform(Ts), repeats)))
    return out


def speed(name, mesh, smoothing, shape, repeats):
    t_dec = {}
    for threads in (1, 2):  # the decomposition's wall time, once per thread count
        t0 = time.perf_counter()
        mr = vpffd.Multires(mesh, smoothing=smoothing, threads=threads)
        t_dec[threads] = time.perf_counter() - t0
    lat = vpffd.Lattice.around(mesh, shape=shape)
    P = np.ascontiguousarray(vpffd.twist(lat.control_points, 90).reshape(-1, 3))
    rows = []
    N0 = vpffd.vertex_normals(mesh)
    for threads in (1, 2):
        d = vpffd.Deformer(mesh, lat, backend="openmp", threads=threads)
        md = vpffd.MultiresDeformer(mr, lat, backend="openmp", threads=threads)
        t_ffd = median_ms(lambda: d._d.ffd(P, threads), repeats)
        t_ffdn = median_ms(lambda: (d._d.ffd(P, threads),
                                    d._d.deformed_normals(P, N0, threads)), repeats)
        t_mr = median_ms(lambda: md._ffd.deform(P, threads), repeats)
        t_mr_pp = median_ms(lambda: md._ffd.deform_per_point(P, threads), repeats)
        t_vol = median_ms(lambda: d.deform(P), repeats)
        t_mrvol = median_ms(lambda: md.deform(P, volume="base"), repeats)
        mt = mesh.n_faces / 1e6
        rows.append((name, mesh.n_vertices, mesh.n_faces, threads, t_ffd, t_ffdn, t_mr, t_vol, t_mrvol,
                     mt / (t_ffd / 1e3), mt / (t_ffdn / 1e3), mt / (t_mr / 1e3), t_mr_pp))
    return mr, t_dec, rows


def accuracy(name, mesh, smoothings, shape):
    out = []
    lat = vpffd.Lattice.around(mesh, shape=shape)
    edits = {"pull 4 (moderate)": pull_four(lat), "bend 90": vpffd.bend(lat.control_points, 90, axis="z"),
             "twist 360": vpffd.twist(lat.control_points, 360, axis="z")}
    diag = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    for s in smoothings:
        mr = vpffd.Multires(mesh, smoothing=s)
        md = vpffd.MultiresDeformer(mr, lat)
        for en, P in edits.items():
            ra = md.deform(P, preserve_volume=False)
            nx = vpffd.vertex_normals(vpffd.Mesh(ra.vertices, mesh.faces))
            moved = np.linalg.norm(ra.vertices - mesh.vertices, axis=1) > 1e-6 * diag
            a = angles_deg(ra.normals, nx)[moved]
            out.append((name, s, en, float(np.abs(mr.displacements).mean() / diag), mr.extrapolated_fraction,
                        float(mr.residuals.max() / diag), float(a.mean()), float(np.percentile(a, 95)),
                        float(a.max())))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="*", default=[6, 7, 8], help="icosphere subdivisions (9: 5.2M tri)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--smoothing", type=float, default=10)
    ap.add_argument("--lattice", type=int, default=8)
    ap.add_argument("--no-shared", action="store_true")
    ap.add_argument("--no-vulkan", action="store_true", help="skip the Vulkan row")
    ap.add_argument("--accuracy-size", type=int, default=5, help="icosphere for the normal-error table")
    ap.add_argument("--meshes", nargs="*", default=["dragon"], choices=sorted(SCANS),
                    help="scans read from ../shared/data/meshes (with --no-shared: none)")
    ap.add_argument("--no-rbf", action="store_true", help="skip the RBF rows")
    ap.add_argument("--rbf-handles", type=int, default=100, help="handle points of the general RBF rows")
    ap.add_argument("--no-accuracy", action="store_true", help="skip the normal-error table")
    a = ap.parse_args()
    print(f"machine: {cpu_model()}, {os.cpu_count()} CPUs, "
          f"load average {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f}; "
          f"lattice {a.lattice}^3 cubic, smoothing {a.smoothing:g}, medians of {a.repeats}")
    print(f"bytes per vertex a frame reads: plain FFD 36 (embedding) + the vertex; multiresolution "
          f"{_core.MultiresFFD.frame_bytes_per_vertex} (float64; half in float32); decomposition holds "
          f"{vpffd.Multires.bytes_per_vertex}")
    print("\n| mesh | V | F | threads | FFD ms | FFD+normals ms | MR ms | VP-FFD ms | MR+VP(base) ms | "
          "FFD Mtri/s | FFD+normals Mtri/s | MR Mtri/s | MR / FFD+normals | MR / FFD | MR per-point ms |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    vk = None if a.no_vulkan else vulkan_selector()
    if vk is not None:
        print(f"vulkan device: {vk[1]}" + (" (a CPU driver: not a GPU figure)" if "llvmpipe" in vk[1] else "")
              + f"; multiresolution {_core.VulkanMultires.frame_bytes_per_vertex} bytes per vertex on the device "
              "(float32)")
    acc_meshes = []
    rbf_rows = []
    for name, mesh in meshes(a.sizes, not a.no_shared, a.meshes):
        mr, t_dec, rows = speed(name, mesh, a.smoothing, (a.lattice,) * 3, a.repeats)
        gpu_ms = None
        if vk is not None:
            lat = vpffd.Lattice.around(mesh, shape=(a.lattice,) * 3)
            P = np.ascontiguousarray(vpffd.twist(lat.control_points, 90).reshape(-1, 3))
            row, gpu_ms, subm = speed_vulkan(name, mesh, mr, lat, P, a.repeats, vk[0])
            rows.append(row)
        for r in rows:
            print(f"| {r[0]} | {r[1]:,} | {r[2]:,} | {r[3]} | {r[4]:.1f} | {r[5]:.1f} | {r[6]:.1f} | {r[7]:.1f} | "
                  f"{r[8]:.1f} | {r[9]:.1f} | {r[10]:.1f} | {r[11]:.1f} | {r[6] / r[5]:.2f} | {r[6] / r[4]:.2f} | "
                  + (f"{r[12]:.1f} |" if len(r) > 12 else "- |"), flush=True)
        if gpu_ms is not None:
            print(f"  ({name}: multiresolution frame on the device, its timestamps: {gpu_ms:.1f} ms)", flush=True)
            print(f"  ({name}: vulkan MR+VP frame, one submission / two through the host: " + "; ".join(
                f"volume {v} {one:.1f} / {two:.1f} ms ({one / two:.2f})" for v, (one, two) in subm.items()) + ")",
                flush=True)
        print(f"  ({name}: decomposition {t_dec[1]:.2f} s on 1 thread, {t_dec[2]:.2f} s on 2; load average "
              f"{os.getloadavg()[0]:.2f}; {mr})", flush=True)
        if not a.no_rbf:
            # Each deformer's frame beside the plain FFD (and the FFD's multiresolution
            # frame) of the same mesh, threads and device, measured in this run.
            ffd = {r[3]: (r[4], r[6]) for r in rows}
            mt = mesh.n_faces / 1e6
            for threads, (t_ffd, t_mr) in ffd.items():
                rbf_rows.append((name, mesh.n_vertices, mesh.n_faces, "FFD multires", threads, "-", t_mr,
                                 mt / (t_mr / 1e3), t_ffd))
            for mode, threads, n_h, t in speed_rbf(mr, mesh, a.rbf_handles, a.repeats, vk):
                if threads in ffd:
                    rbf_rows.append((name, mesh.n_vertices, mesh.n_faces, mode, threads, n_h, t,
                                     mt / (t / 1e3), ffd[threads][0]))
            print(f"  ({name}: RBF rows done; load average {os.getloadavg()[0]:.2f})", flush=True)
        if name == "dragon":
            acc_meshes.append((name, mesh))
    if rbf_rows:
        print("\n| mesh | V | F | deformer | threads | constraints H | frame ms | Mtri/s | plain FFD ms | "
              "frame / plain FFD |")
        print("|---|---:|---:|---|---|---:|---:|---:|---:|---:|")
        for r in rbf_rows:
            print(f"| {r[0]} | {r[1]:,} | {r[2]:,} | {r[3]} | {r[4]} | {r[5]} | {r[6]:.1f} | {r[7]:.1f} | "
                  f"{r[8]:.1f} | {r[6] / r[8]:.2f} |")
        print(f"(load average after the RBF rows: {' '.join(f'{x:.2f}' for x in os.getloadavg())})", flush=True)
    if a.no_accuracy:
        print(f"\nload average at the end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
        return
    acc_meshes.insert(0, (f"bumpy ico{a.accuracy_size}", vpffd.shapes.bumpy_sphere(a.accuracy_size)))
    acc_meshes.insert(1, ("bumpy body", vpffd.shapes.bumpy_sphere(a.accuracy_size, stretch=(1, 1, 2.5))))
    print("\n| mesh | smoothing | edit | mean |d| / diag | extrapolated | max residual / diag | mean deg | "
          "p95 deg | max deg |")
    print("|---|---:|---|---:|---:|---:|---:|---:|---:|")
    for name, mesh in acc_meshes:
        smoothings = (a.smoothing,) if name == "dragon" else (3, 10, 30)
        for r in accuracy(name, mesh, smoothings, (a.lattice,) * 3):
            print(f"| {r[0]} | {r[1]:g} | {r[2]} | {r[3]:.2e} | {100 * r[4]:.1f} % | {r[5]:.2e} | {r[6]:.3f} | "
                  f"{r[7]:.2f} | {r[8]:.1f} |", flush=True)
    print(f"\nload average at the end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
