#!/usr/bin/env python
"""Benchmark of displaced subdivision surface frames (Marinov et al., Table I).

    .venv/bin/python bench/python/bench_subdiv.py [--repeats 15] [--no-shared] [--no-dragon] [--out FILE.md]

Per mesh (near the paper's 62K, 137K and 667K triangles: the bunny from
../shared/data/meshes, bumpy latitude-longitude spheres made in code with exactly
137K and 667K triangles, and the dragon, 871K, when present), a Loop control mesh of
1 % of the vertices (OpenMesh decimation, 2 fit rounds), then frames per second on the
CPU with 1 and 2 threads (medians of --repeats frames after a warm-up):

  * full frame: every fine vertex from all control points (the stencils of S, S_u,
    S_v, p' = S' + d N_S', approximate normals of eqs. 6-7); its cost does not depend
    on how many control points moved, so one column serves 1, 4 and 10;
  * k = 1, 4, 10 edited control vertices as an affine group (§5.2.2): the k control
    points nearest the front, translated; a frame copies the held frame and rebuilds
    only the vertices the group reaches (21 numbers each);
  * an affine group edit of a larger region (the 5 % of control points nearest the
    front, rotated 20 degrees and translated), the paper's "affine transformation of
    a larger number of control vertices".

Frames are timed at the binding (the C++ frame, results returned as numpy arrays;
no volumes). Then the decomposition time (2 threads, once) and the bytes per
vertex: what a full frame reads, and what a group holds. The Vulkan frame
(`deform(backend="vulkan")`) is not timed here: on a machine without a GPU its only
device is lavapipe, a CPU driver, whose times say nothing about a GPU.
Writes the markdown table to --out (default bench/results/<machine>/subdiv_<machine>.md;
machine: $VPFFD_BENCH_MACHINE, else the host name) and stdout.
"""
import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

import vpffd

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "data" / "meshes"


def cpu_name() -> str:
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def median_fps(f, repeats):
    f()  # warm-up: page faults of fresh buffers, caches
    t = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        t.append(time.perf_counter() - t0)
    return 1.0 / float(np.median(t)), 1e3 * float(np.median(t))


def bumpy_uv_sphere(triangles: int) -> vpffd.Mesh:
    """A latitude-longitude sphere of about ``triangles`` triangles (2 (r - 1) s),
    with bumpy_sphere's radial bumps."""
    n = int(round(np.sqrt(triangles / 2.0)))
    m = vpffd.shapes.uv_sphere(n + 1, n)
    U = m.vertices
    r = 1.0 + 0.04 * np.sin(9 * U[:, 0]) * np.sin(9 * U[:, 1]) * np.sin(9 * U[:, 2])
    return vpffd.Mesh(U * r[:, None], m.faces)


def meshes(shared: bool, dragon: bool):
    if shared and (SHARED / "bunny_watertight.ply").exists():
        yield "bunny", vpffd.load_mesh(SHARED / "bunny_watertight.ply")
    yield "bumpy uv-sphere 137K", bumpy_uv_sphere(137_000)
    yield "bumpy uv-sphere 667K", bumpy_uv_sphere(667_000)
    if shared and dragon and (SHARED / "dragon_vrip_welded.ply.gz").exists():
        yield "dragon", vpffd.load_mesh(SHARED / "dragon_vrip_welded.ply.gz")


def front(sm, k):
    """The k control points nearest the front (largest x) control point."""
    C = sm.control_points
    tip = C[np.argmax(C[:, 0])]
    return np.argsort(np.linalg.norm(C - tip, axis=1))[:k]


def rotation_z(deg, centre, shift):
    a = np.radians(deg)
    R = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = centre - R @ centre + shift
    return T


def bench_mesh(name, mesh, repeats):
    t0 = time.perf_counter()
    sm = vpffd.SubdivisionMultires(mesh, control_vertices=max(64, mesh.n_vertices // 100),
                                   max_unresolved=mesh.n_vertices, threads=2)
    wall = time.perf_counter() - t0
    diag = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    C = np.array(sm.control_points)
    C[front(sm, 10), 0] += 0.05 * diag
    shift = np.array([0.05 * diag, 0.0, 0.0])
    groups = {k: sm.affine_group(front(sm, k)) for k in (1, 4, 10)}
    big = max(11, sm.n_control // 20)
    groups["affine"] = sm.affine_group(front(sm, big))
    T_move = rotation_z(0.0, np.zeros(3), shift)
    T_affine = rotation_z(20.0, sm.control_points[front(sm, big)].mean(axis=0), shift)
    rows = []
    for threads in (1, 2):
        full = median_fps(lambda: sm._m.deform(C, threads), repeats)
        cols = {"full": full}
        for key, g in groups.items():
            T = T_affine if key == "affine" else T_move
            cols[key] = median_fps(lambda g=g, T=T: sm._m.deform_affine(g._g, T, threads), repeats)
        rows.append((threads, cols))
    info = dict(V=mesh.n_vertices, F=mesh.n_faces, M=sm.n_control, seconds=sm.seconds, wall=wall,
                unresolved=len(sm.unresolved), rms=(sm.rms_initial, sm.rms_final), bpv=sm.bytes_per_vertex,
                reach={k: len(g.influenced) for k, g in groups.items()}, big=big,
                group_bpv={k: g.bytes_per_vertex for k, g in groups.items()}, diag=diag)
    return rows, info


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--no-shared", action="store_true", help="meshes made in code only")
    ap.add_argument("--no-dragon", action="store_true", help="skip the dragon (its decomposition takes longest)")
    machine = os.environ.get("VPFFD_BENCH_MACHINE") or platform.node() or "host"
    ap.add_argument("--out", default=str(ROOT / "bench" / "results" / machine / f"subdiv_{machine}.md"))
    a = ap.parse_args()
    if not vpffd.subdivision.available():
        raise SystemExit("bench_subdiv: this build has no vpffd::subdiv (install libosd-dev and rebuild)")
    lines = []

    def out(s=""):
        print(s, flush=True)
        lines.append(s)

    out("# Displaced subdivision surfaces: frames per second (Marinov et al., Table I)")
    out("")
    out(f"machine: {cpu_name()}, {os.cpu_count()} CPUs (a shared virtual machine: other work runs beside, "
        f"so the figures are ratios within this run); load average {load()} at the start; "
        f"OpenMP {vpffd._core.has_openmp()}; medians of {a.repeats} frames")
    out("Vulkan: not timed here (the frame exists: deform(backend='vulkan'); on a machine without a GPU its only "
        "device is lavapipe, a CPU driver).")
    out("")
    out("| mesh | V | triangles | control points | threads | full frame fps (ms) | 1 CV fps (ms) | "
        "4 CV fps (ms) | 10 CV fps (ms) | affine group fps (ms) |")
    out("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    notes = []
    for name, mesh in meshes(not a.no_shared, not a.no_dragon):
        rows, info = bench_mesh(name, mesh, a.repeats)
        for threads, cols in rows:
            cells = " | ".join(f"{cols[k][0]:.0f} ({cols[k][1]:.2f})" for k in ("full", 1, 4, 10, "affine"))
            out(f"| {name} | {info['V']:,} | {info['F']:,} | {info['M']:,} | {threads} | {cells} |")
        notes.append(f"- {name}: decomposition {info['seconds']:.1f} s on 2 threads ({info['wall']:.1f} s with the "
                     f"Python side), {info['unresolved']} unresolved foot points, fit RMS {info['rms'][0]:.3g} -> "
                     f"{info['rms'][1]:.3g} (diagonal {info['diag']:.3g}); a full frame reads "
                     f"{info['bpv']:.0f} bytes per vertex; the groups of 1, 4, 10 and {info['big']} control points "
                     f"reach {info['reach'][1]:,}, {info['reach'][4]:,}, {info['reach'][10]:,} and "
                     f"{info['reach']['affine']:,} vertices and hold "
                     + ", ".join(f"{info['group_bpv'][k]:.0f}" for k in (1, 4, 10, "affine"))
                     + f" bytes per vertex; load average {load()}")
        print(notes[-1], flush=True)
    out("")
    out("CV: edited control vertices, moved as an affine group (translation); affine group: 5 % of the control "
        "points rotated and translated. A group frame copies the held frame of every vertex and rebuilds the "
        "vertices the group reaches; a full frame rebuilds every vertex from all control points, whatever "
        "moved. On the large meshes a group frame's time is mostly the copy of the held frame (positions, "
        "normals and base points, 72 bytes per vertex), not the rebuild.")
    out("")
    for n in notes:
        out(n)
    out("")
    out(f"load average at the end: {load()}")
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)  # a new machine's folder
    Path(a.out).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
