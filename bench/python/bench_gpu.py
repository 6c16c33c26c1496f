#!/usr/bin/env python3
"""The paper's Table 2 for vpffd: GPU (Vulkan) against CPU frame times.

For each mesh (an icosphere and the closed meshes of ../shared/data/meshes):
vertices, GPU FFD, CPU VOL (one axis), GPU VOL (one axis), the full xyz frame on
CPU and GPU, and the factor CPU/GPU for the xyz frame. GPU stage times come from
Vulkan timestamp queries inside the frame's single submission; "GPU xyz e2e" is
the whole Deformer.deform call as a caller sees it (upload, submit, wait, read
back of offsets and vertices), "GPU xyz kept" the same with the vertices left on
the device (a renderer's case). "GPU xyz+N" is the xyz frame with the deformed
normals computed in the same submission (deform(normals=True)), "CPU N" the CPU's
deformed_normals of the same control points alone, "N angle deg" the largest angle
between the two. CPU times are the OpenMP backend.

    python bench/python/bench_gpu.py                  # all meshes, 10^3 cubic lattice
    python bench/python/bench_gpu.py --max-vertices 50000 --repeats 3
    VPFFD_VULKAN_DEVICE=llvmpipe python bench/python/bench_gpu.py

Scaling (--scaling): icospheres built in code, subdivision 5 (20 k triangles) up
to --max-subdiv (default 9: 5.2 M triangles; 10: 21 M triangles, about 5-10 GB of
host memory and 1-2 GB of GPU memory), and the time per xyz frame against the
number of triangles, with a least-squares line t = a + b * faces and each size's
time per triangle: a GPU frame should grow linearly once the fixed cost a is
amortised. On lavapipe keep to --max-subdiv 8 (1.3 M triangles, seconds a frame).

    python bench/python/bench_gpu.py --scaling                 # up to 5.2 M triangles
    python bench/python/bench_gpu.py --scaling --max-subdiv 10 --repeats 5 --no-cpu

On a GPU machine without internet (Python 3.12, CMake, pybind11 and
scikit-build-core installed) the module is built from this tree with carried
Debian packages: see bench/README.md.

On lavapipe (the CPU Vulkan driver) only correctness counts: its table is printed
too, but says nothing about GPU speed. Results go to
bench/results/<machine>/gpu_<device>.csv/.json (--scaling: gpu_scaling_<device>.csv/.json;
machine: $VPFFD_BENCH_MACHINE, else the host name; bench/gpu_machine.sh names it after the GPU).
"""
from __future__ import annotations

import argparse
import csv
import gzip
import json
import os
import platform
import re
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import vpffd
from vpffd._files import open_replacing, write_text  # checked writes: a failure leaves the old file

from vpffd.cli.benchmark import SHARED_MESHES, cpu_model, frame_edit as edit, load_average as load, median_ms, run_for
from vpffd.normals import angles_deg, deformed_normals

import _floor  # bench/python: the memory floor of a frame
from _floor import copy_bandwidth, floor_ms

ROOT = Path(__file__).resolve().parents[2]


def read_ply(path):
    """Binary little-endian PLY with float32 x, y, z and 'list uchar int' triangles (gzipped or not).

    Not vpffd.load_mesh: the GPU machine's build (bench/README.md) carries no OpenMesh."""
    raw = (gzip.open if str(path).endswith(".gz") else open)(path, "rb").read()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    header = raw[:end].decode("ascii").splitlines()
    # Only the layout this reader handles; anything else would be misread silently.
    layout = [h.split() for h in header if h.split()[:1] in (["format"], ["element"], ["property"])]
    want = [["format", "binary_little_endian", "1.0"], ["element", "vertex"], ["property", "float", "x"],
            ["property", "float", "y"], ["property", "float", "z"], ["element", "face"],
            ["property", "list", "uchar", "int"]]
    if len(layout) != len(want) or any(h[:len(w)] != w for h, w in zip(layout, want)):
        raise ValueError(f"{path}: read_ply takes binary little-endian PLY with float x, y, z and "
                         "'list uchar int' faces only")
    nv = next(int(h.split()[2]) for h in header if h.startswith("element vertex"))
    nf = next(int(h.split()[2]) for h in header if h.startswith("element face"))
    V = np.frombuffer(raw, dtype="<f4", count=3 * nv, offset=end).reshape(nv, 3).astype(np.float64)
    rec = np.dtype([("n", "u1"), ("i", "<i4", (3,))])
    F = np.frombuffer(raw, dtype=rec, count=nf, offset=end + 12 * nv)
    if not (F["n"] == 3).all():
        raise ValueError(f"{path}: not a triangle mesh")
    return vpffd.Mesh(V, F["i"].astype(np.int32))


def meshes(max_vertices):
    out = [("icosphere5", vpffd.shapes.icosphere(5))]
    if SHARED_MESHES.is_dir():
        for p in sorted(SHARED_MESHES.iterdir()):
            if p.name.startswith("BADINPUT") or not re.search(r"\.ply(\.gz)?$", p.name):
                continue
            out.append((re.sub(r"\.ply(\.gz)?$", "", p.name), p))
    for name, m in out:
        mesh = m if isinstance(m, vpffd.Mesh) else read_ply(m)
        if max_vertices and mesh.n_vertices > max_vertices:
            print(f"skip {name}: {mesh.n_vertices} vertices > --max-vertices {max_vertices}", file=sys.stderr)
            continue
        yield name, mesh


def stage_medians(timings) -> dict:
    """Medians of a frame's host stages (Deformer.last_timings): preparing and staging,
    submission until the queue is idle, the read back into the caller's order, and the
    Python wrapper around the core's call; the device's read back (the vertices put in
    the caller's order and copied to host memory); and what is left of the Python call
    without the device's work (the frame's and the read back's)."""
    med = statistics.median
    return dict(stage_prepare_ms=med(t["host_prepare_ms"] for t in timings),
                stage_submit_wait_ms=med(t["host_submit_wait_ms"] for t in timings),
                stage_unpack_ms=med(t["host_unpack_ms"] for t in timings),
                stage_python_ms=med(t["python_total_ms"] - t["host_total_ms"] for t in timings),
                gpu_readback_ms=med(t.get("gpu_readback_ms", 0.0) for t in timings),
                host_minus_device_ms=med(t["python_total_ms"] - t["gpu_total_ms"] - t.get("gpu_readback_ms", 0.0)
                                         for t in timings))


def bench_mesh(name, mesh, args):
    lat = vpffd.Lattice.around(mesh, shape=args.shape, degree=args.degree)
    P = edit(lat)
    cpu = vpffd.Deformer(mesh, lat, backend="openmp" if vpffd._core.has_openmp() else "serial")
    gpu = vpffd.Deformer(mesh, lat, backend="vulkan", device=args.device, gpu_precision=args.precision)
    r = args.repeats
    cpu.deform(P)  # warm caches
    cpu_ffd = median_ms(lambda: cpu.ffd(P), r)
    cpu_x = median_ms(lambda: cpu.deform(P, axes="x"), r)
    cpu_xyz = median_ms(lambda: cpu.deform(P), r)

    for _ in range(2):  # shader compilation (JIT on lavapipe), first-touch of memory
        gpu.deform(P)
    Pflat = np.ascontiguousarray(P.reshape(-1, 3))
    run_for(lambda: gpu._vk.deform(Pflat, read_vertices=False), args.warmup)  # the GPU's clock up
    gx = []
    for _ in range(r):
        gpu.deform(P, axes="x")
        gx.append(gpu.last_timings())
    gxyz, e2e, kept = [], [], []
    for _ in range(r):
        t0 = time.perf_counter()
        res = gpu.deform(P)
        e2e.append((time.perf_counter() - t0) * 1e3)
        gxyz.append(gpu.last_timings())
    for _ in range(r):
        t0 = time.perf_counter()
        gpu._vk.deform(Pflat, read_vertices=False)
        kept.append((time.perf_counter() - t0) * 1e3)
    # Normals in the same submission (normals.comp): the extra cost over the xyz frame,
    # and the CPU's deformed_normals of the same control points for comparison.
    gn, gn_e2e = [], []
    for _ in range(r):
        t0 = time.perf_counter()
        resn = gpu.deform(P, normals=True)
        gn_e2e.append((time.perf_counter() - t0) * 1e3)
        gn.append(gpu.last_timings())
    cpu_normals = median_ms(lambda: deformed_normals(cpu, resn.control_points), r)
    ref_normals = deformed_normals(cpu, resn.control_points)
    ref = cpu.deform(P)
    diag = float(np.linalg.norm(lat.box_max - lat.box_min))
    med = statistics.median
    row = dict(
        model=name, vertices=mesh.n_vertices, faces=int(mesh.faces.shape[0]), precision=gpu.gpu_precision,
        lattice=f"{args.shape}^3 deg {args.degree}",
        gpu_ffd_ms=med(t["gpu_ffd_ms"] for t in gx),
        cpu_ffd_ms=cpu_ffd,
        cpu_vol_x_ms=max(cpu_x - cpu_ffd, 0.0),
        gpu_vol_x_ms=med(t["gpu_steps_ms"][0] for t in gx),
        cpu_xyz_ms=cpu_xyz,
        gpu_xyz_ms=med(t["gpu_total_ms"] for t in gxyz),
        gpu_xyz_e2e_ms=med(e2e),
        gpu_xyz_kept_ms=med(kept),
        **stage_medians(gxyz),
        gpu_xyz_normals_ms=med(t["gpu_total_ms"] for t in gn),
        gpu_xyz_normals_e2e_ms=med(gn_e2e),
        cpu_normals_ms=cpu_normals,
        normals_max_angle_deg=float(np.nanmax(angles_deg(resn.normals, ref_normals))),
        volume_error_gpu=res.volume_error,
        volume_error_cpu=ref.volume_error,
        max_vertex_dev_rel=float(np.abs(res.vertices - ref.vertices).max() / diag),
    )
    row["factor"] = row["cpu_xyz_ms"] / row["gpu_xyz_e2e_ms"]
    row["e2e_over_floor"] = row["gpu_xyz_e2e_ms"] / floor_ms(mesh.n_vertices, args.bandwidth)
    return row


def bench_scaling(args, device, precision):
    """Time per xyz frame against triangles on subdivided icospheres."""
    rows = []
    r = args.repeats
    for s in range(args.min_subdiv, args.max_subdiv + 1):
        faces = 20 * 4 ** s
        print(f"icosphere({s}): {faces} triangles ...", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        mesh = vpffd.shapes.icosphere(s)
        lat = vpffd.Lattice.around(mesh, shape=args.shape, degree=args.degree)
        P = edit(lat)
        Pflat = np.ascontiguousarray(P.reshape(-1, 3))
        gpu = vpffd.Deformer(mesh, lat, backend="vulkan", device=args.device, gpu_precision=args.precision)
        setup_s = time.perf_counter() - t0
        first = gpu.deform(P)  # shader JIT, first touch
        run_for(lambda: gpu._vk.deform(Pflat, read_vertices=False), args.warmup)  # the GPU's clock up
        gt, kept, e2e, e2e_out, staged = [], [], [], [], []
        for _ in range(r):
            t0 = time.perf_counter()
            gpu._vk.deform(Pflat, read_vertices=False)
            kept.append((time.perf_counter() - t0) * 1e3)
            gt.append(gpu.last_timings())
        out = np.empty((mesh.n_vertices, 3))
        for _ in range(max(1, r // 2)):
            t0 = time.perf_counter()
            gpu.deform(P)
            e2e.append((time.perf_counter() - t0) * 1e3)
            staged.append(gpu.last_timings())
            t0 = time.perf_counter()
            gpu.deform(P, out=out)
            e2e_out.append((time.perf_counter() - t0) * 1e3)
        med = statistics.median
        row = dict(subdiv=s, vertices=mesh.n_vertices, faces=faces, setup_s=setup_s,
                   gpu_xyz_ms=med(t["gpu_total_ms"] for t in gt), gpu_ffd_ms=med(t["gpu_ffd_ms"] for t in gt),
                   gpu_step_ms=med(statistics.mean(t["gpu_steps_ms"]) for t in gt),
                   gpu_xyz_kept_ms=med(kept), gpu_xyz_e2e_ms=med(e2e), gpu_xyz_e2e_out_ms=med(e2e_out),
                   volume_error_gpu=first.volume_error, **stage_medians(staged))
        # What the host adds to the device's frame, per vertex, frame by frame (the
        # Python call end to end less its own device time; the target: 1.5 ns on lavapipe).
        row["host_ns_per_vertex"] = row["host_minus_device_ms"] * 1e6 / mesh.n_vertices
        floor = floor_ms(mesh.n_vertices, args.bandwidth)
        row["e2e_over_floor"] = row["gpu_xyz_e2e_ms"] / floor
        row["e2e_out_over_floor"] = row["gpu_xyz_e2e_out_ms"] / floor
        row["ns_per_face"] = row["gpu_xyz_ms"] * 1e6 / faces
        if args.readback_ab:
            # The same frames read back in the device's order and reordered on the host
            # (VPFFD_VULKAN_READBACK=host): the A/B of the caller's order made on the device.
            os.environ["VPFFD_VULKAN_READBACK"] = "host"
            try:
                ref = vpffd.Deformer(mesh, lat, backend="vulkan", device=args.device, gpu_precision=args.precision)
            finally:
                del os.environ["VPFFD_VULKAN_READBACK"]
            ref.deform(P, out=out)
            hr = []
            for _ in range(max(1, r // 2)):
                t0 = time.perf_counter()
                ref.deform(P, out=out)
                hr.append((time.perf_counter() - t0) * 1e3)
            row["gpu_xyz_e2e_out_host_order_ms"] = med(hr)
            row["host_order_unpack_ms"] = ref.last_timings()["host_unpack_ms"]
            del ref
        if args.cpu:
            cpu = gpu._d  # the CPU core of the same mesh (all OpenMP threads), no second embedding
            cpu.deform(Pflat)
            row["cpu_xyz_ms"] = median_ms(lambda: cpu.deform(Pflat), max(1, r // 2))
        rows.append(row)
        del gpu, mesh
    # t = a + b * faces over the sizes where the fixed cost no longer dominates.
    big = [x for x in rows if x["faces"] >= 300_000] or rows
    if len(big) >= 2:
        b, a = np.polyfit([x["faces"] for x in big], [x["gpu_xyz_ms"] for x in big], 1)
    else:
        a, b = 0.0, big[0]["gpu_xyz_ms"] / big[0]["faces"]
    cols = [("subdiv", "{}"), ("vertices", "{}"), ("faces", "{}"), ("gpu_xyz_ms", "{:.3f}"),
            ("gpu_ffd_ms", "{:.3f}"), ("gpu_step_ms", "{:.3f}"), ("gpu_xyz_kept_ms", "{:.3f}"),
            ("gpu_xyz_e2e_ms", "{:.3f}"), ("gpu_xyz_e2e_out_ms", "{:.3f}"), ("stage_prepare_ms", "{:.3f}"),
            ("stage_submit_wait_ms", "{:.3f}"), ("stage_unpack_ms", "{:.3f}"), ("stage_python_ms", "{:.3f}"),
            ("gpu_readback_ms", "{:.3f}"), ("host_ns_per_vertex", "{:.2f}"), ("e2e_over_floor", "{:.1f}"),
            ("e2e_out_over_floor", "{:.1f}"), ("ns_per_face", "{:.3f}")] + \
        ([("gpu_xyz_e2e_out_host_order_ms", "{:.3f}"), ("host_order_unpack_ms", "{:.3f}")] if args.readback_ab
         else []) + ([("cpu_xyz_ms", "{:.2f}")] if args.cpu else []) + [("volume_error_gpu", "{:.1e}"), ("setup_s", "{:.1f}")]
    print(f"\nScaling (ms per xyz frame, medians of {r}) on {device['name']} ({device['type']}, {precision} sums), "
          f"{args.shape}^3 lattice of degree {args.degree}")
    cells = [[fmt.format(x[k]) for k, fmt in cols] for x in rows]
    width = [max(len(k), *(len(c[i]) for c in cells)) for i, (k, _) in enumerate(cols)]
    print("  ".join(k.rjust(w) for (k, _), w in zip(cols, width)))
    for c in cells:
        print("  ".join(v.rjust(w) for v, w in zip(c, width)))
    print(f"load average {load()}")
    print(floor_note(args.bandwidth))
    print(f"fit over >= 300k triangles: gpu_xyz_ms = {a:.3f} + {b * 1e6:.3f} ms per million triangles")
    if device["type"] == "cpu":
        print("(a software Vulkan device: these GPU times only show that the path runs, not GPU speed)")
    return rows, dict(fixed_ms=a, ms_per_million_faces=b * 1e6)


COLUMNS = [("model", "model", "{}"), ("vertices", "vertices", "{}"), ("gpu_ffd_ms", "GPU FFD", "{:.2f}"),
           ("cpu_vol_x_ms", "CPU VOL(x)", "{:.2f}"), ("gpu_vol_x_ms", "GPU VOL(x)", "{:.2f}"),
           ("cpu_xyz_ms", "CPU xyz", "{:.2f}"), ("gpu_xyz_ms", "GPU xyz", "{:.2f}"),
           ("gpu_xyz_e2e_ms", "GPU xyz e2e", "{:.2f}"), ("gpu_xyz_kept_ms", "GPU xyz kept", "{:.2f}"),
           ("factor", "factor", "{:.2f}"), ("e2e_over_floor", "e2e / floor", "{:.1f}"), ("volume_error_gpu", "vol err GPU", "{:.1e}"),
           ("max_vertex_dev_rel", "dev/diag", "{:.1e}"), ("gpu_xyz_normals_ms", "GPU xyz+N", "{:.2f}"),
           ("cpu_normals_ms", "CPU N", "{:.2f}"), ("normals_max_angle_deg", "N angle deg", "{:.1e}")]


def print_table(rows, device, precision, bandwidth):
    print(f"\nTable 2 (ms, medians) on {device['name']} ({device['type']}, {precision} sums); CPU: {cpu_model()}, "
          f"{os.cpu_count()} cores; load average {load()}")
    head = [c[1] for c in COLUMNS]
    cells = [[fmt.format(r[k]) for k, _, fmt in COLUMNS] for r in rows]
    width = [max(len(h), *(len(c[i]) for c in cells)) for i, h in enumerate(head)]
    print("  ".join(h.rjust(w) for h, w in zip(head, width)))
    for c in cells:
        print("  ".join(x.rjust(w) for x, w in zip(c, width)))
    print(floor_note(bandwidth))
    if device["type"] == "cpu":
        print("(a software Vulkan device: these GPU times only show that the path runs, not GPU speed)")


def floor_note(bandwidth: float) -> str:
    return (_floor.note(bandwidth) + ". host_ns_per_vertex: the Python call less the device's frame and read "
            "back, per vertex")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--shape", type=int, default=10, help="control points per axis (default 10)")
    ap.add_argument("--degree", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--warmup", type=float, default=1.0,
                    help="seconds of untimed frames before each mesh's timings (GPU clocks ramp up under load)")
    ap.add_argument("--max-vertices", type=int, default=0, help="skip larger meshes (0: none)")
    ap.add_argument("--device", default=os.environ.get("VPFFD_VULKAN_DEVICE", ""),
                    help="Vulkan device index or name part (default: VPFFD_VULKAN_DEVICE, else the first suitable)")
    ap.add_argument("--precision", default="auto", choices=["auto", "float64", "float-float"],
                    help="how the device sums (default auto: float64 where the device has it); the result files "
                         "of float-float runs end in _ff")
    ap.add_argument("--out", default=str(ROOT / "bench" / "results" / (os.environ.get("VPFFD_BENCH_MACHINE") or platform.node() or "host")))
    ap.add_argument("--scaling", action="store_true",
                    help="time per frame against triangles on icospheres built in code (see above)")
    ap.add_argument("--max-subdiv", type=int, default=9,
                    help="--scaling: largest icosphere subdivision (9: 5.2 M triangles, 10: 21 M)")
    ap.add_argument("--min-subdiv", type=int, default=5, help="--scaling: smallest icosphere subdivision")
    ap.add_argument("--readback-ab", action="store_true",
                    help="--scaling: also time the frames with VPFFD_VULKAN_READBACK=host (the device's vertex "
                         "order reordered on the host)")
    ap.add_argument("--no-cpu", dest="cpu", action="store_false", help="--scaling: skip the CPU frame times")
    args = ap.parse_args(argv)
    if not vpffd._core.has_vulkan:
        sys.exit("bench_gpu: this vpffd build has no Vulkan backend")
    args.bandwidth = copy_bandwidth()
    probe = vpffd.Deformer(vpffd.shapes.icosphere(1), vpffd.Lattice.around(vpffd.shapes.icosphere(1), shape=4),
                           backend="vulkan", device=args.device, gpu_precision=args.precision)
    device = probe.device
    load_start = load()
    slug = re.sub(r"[^A-Za-z0-9]+", "_", device["name"]).strip("_").lower()
    if probe.gpu_precision == "float-float":
        slug += "_ff"
    out = Path(args.out)
    if args.scaling:
        rows, fit = bench_scaling(args, device, probe.gpu_precision)
        out.mkdir(parents=True, exist_ok=True)
        with open_replacing(out / f"gpu_scaling_{slug}.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        meta = dict(device=device, cpu=cpu_model(), load_start=load_start, load_end=load(), cores=os.cpu_count(), python=platform.python_version(),
                    vpffd=vpffd.__version__, precision=probe.gpu_precision, shape=args.shape, degree=args.degree,
                    repeats=args.repeats, fit=fit, copy_bandwidth_bytes_per_s=args.bandwidth,
                    rows=rows)
        write_text(out / f"gpu_scaling_{slug}.json", json.dumps(meta, indent=1))
        print(f"wrote {out / f'gpu_scaling_{slug}.csv'} and .json", file=sys.stderr)
        return
    rows = []
    for name, mesh in meshes(args.max_vertices):
        print(f"{name}: {mesh.n_vertices} vertices ...", file=sys.stderr, flush=True)
        rows.append(bench_mesh(name, mesh, args))
    if not rows:
        sys.exit(f"bench_gpu: no mesh has at most --max-vertices {args.max_vertices} vertices")
    print_table(rows, device, probe.gpu_precision, args.bandwidth)
    out.mkdir(parents=True, exist_ok=True)
    with open_replacing(out / f"gpu_{slug}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]) if rows else ["model"])
        w.writeheader()
        w.writerows(rows)
    meta = dict(device=device, cpu=cpu_model(), load_start=load_start, load_end=load(), cores=os.cpu_count(), python=platform.python_version(),
                vpffd=vpffd.__version__, precision=probe.gpu_precision, shape=args.shape, degree=args.degree,
                repeats=args.repeats, copy_bandwidth_bytes_per_s=args.bandwidth, rows=rows)
    write_text(out / f"gpu_{slug}.json", json.dumps(meta, indent=1))
    print(f"wrote {out / f'gpu_{slug}.csv'} and .json", file=sys.stderr)


if __name__ == "__main__":
    main()
