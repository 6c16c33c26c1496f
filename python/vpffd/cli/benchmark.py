"""CPU benchmark of a volume-preserving frame (the README's table).

For each mesh: nnz of the paper's N x F matrix (its Table 1), and the median
times of the plain FFD, one axis correction and the full xyz frame, for the
``traversal`` and ``csr`` coefficient methods on 1 thread and on all threads;
and where an xyz frame's time goes (the frame's own per-pass clocks, medians).
"""
from __future__ import annotations

import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from .. import _core, edits, shapes
from .._files import write_text
from ..deformer import Deformer
from ..io import load_mesh
from ..lattice import Lattice
from ..mesh import Mesh

# VPFFD_SHARED_MESHES: where the meshes are on a machine without ../shared (a GPU machine).
SHARED_MESHES = Path(os.environ.get("VPFFD_SHARED_MESHES")
                     or Path(__file__).resolve().parents[3].parent / "shared" / "data" / "meshes")  # checkout/../shared


def frame_edit(lat: Lattice) -> np.ndarray:
    """The benchmarks' frame: the lattice squashed to 60 % height, then twisted 90°."""
    return edits.twist(edits.squash(lat.control_points, 0.6), 90)


def median_ms(fn, repeats: int) -> float:
    """Median wall time of fn() over `repeats` runs after one warm-up run, ms."""
    fn()  # warm-up
    t = []
    for _ in range(repeats):
        s = time.perf_counter()
        fn()
        t.append(time.perf_counter() - s)
    return 1e3 * float(np.median(t))


def cpu_model() -> str:
    """The CPU's model name for a results file (platform.processor() is empty on most
    Linux machines)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def load_average() -> str:
    """The 1, 5 and 15-minute load averages, e.g. "0.52 0.61 0.70"."""
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def run_for(fn, seconds: float) -> None:
    """Calls fn() back to back for `seconds` (untimed). A GPU idles at a low clock
    (an H100 at 345 of 1980 MHz) that short bursts of frames do not raise; the
    GPU benchmarks run this before timing (without it an H100's frames on large
    meshes came out 4-5x slower)."""
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        fn()


# The passes of a frame as the core times them (CorrectionOptions::record_timings).
PASSES = ("plan", "ffd", "coefficients", "solves", "gathers", "volume", "reorder")


def frame_breakdown(d: Deformer, P, repeats: int, axes: str = "xyz", method: str = "traversal") -> dict:
    """Median ms per pass of a frame over ``repeats`` runs (after one warm-up), and of
    the whole frame ("total"): ffd = plain FFD, coefficients = the weight and scatter
    passes of every axis step, solves = the closed-form offsets, gathers = the offset
    fields at the vertices (the last fused with the volume),
    volume = separate volume passes, reorder = the copy to the caller's vertex order."""
    Pf = d._P(P)
    opts = _core.CorrectionOptions(axes=axes, method=method, threads=d._threads, record_timings=True)
    runs = [d._d.deform(Pf, opts)["timings"]
            for _ in range(repeats + 1)][1:]
    return {k: float(np.median([r[k + "_ms"] for r in runs])) for k in (*PASSES, "total")}


def bench_mesh(name: str, mesh: Mesh, shape=(10, 10, 10), degree=3, repeats=7, with_csr=True) -> list:
    """Rows of the table for one mesh (dicts)."""
    lat = Lattice.around(mesh, shape=shape, degree=degree, padding=0.05)
    P = frame_edit(lat)
    rows = []
    threads = [("serial", 1), ("openmp", None)] if _core.has_openmp() else [("serial", 1)]
    nnz = None
    for backend, th in threads:
        d = Deformer(mesh, lat, backend=backend, threads=th)
        methods = ["traversal"] + (["csr"] if with_csr else [])
        for method in methods:
            if method == "csr" and nnz is None:
                t0 = time.perf_counter()
                nnz = d.face_matrix_nnz()
                build_s = time.perf_counter() - t0
            elif method == "csr":
                d.face_matrix_nnz()
            r = d.deform(P, method=method)
            rows.append(dict(
                mesh=name, vertices=mesh.n_vertices, faces=mesh.n_faces, lattice="x".join(map(str, shape)),
                degree=degree, backend=backend, threads=th or _core.max_threads(), method=method,
                ffd_ms=median_ms(lambda: d.ffd(P), repeats),
                one_axis_ms=median_ms(lambda: d.deform(P, axes="x", method=method), repeats),
                xyz_ms=median_ms(lambda: d.deform(P, axes="xyz", method=method), repeats),
                volume_error=r.volume_error, bytes_per_vertex=d.bytes_per_vertex,
                csr_nnz=nnz if method == "csr" else None,
                csr_build_s=build_s if method == "csr" and backend == threads[0][0] else None,
                breakdown_ms=frame_breakdown(d, P, repeats, method=method),
                options_ms=option_costs(d, P, repeats) if method == "traversal" else None))
    return rows


# What the frame options of Deformer.deform cost beside the plain xyz frame.
OPTIONS = (("normals", dict(normals=True)), ("auto weights", dict(weights="auto")),
           ("fold check", dict(on_fold="warn")))


def option_costs(d: Deformer, P, repeats: int) -> dict:
    """Median ms of the xyz frame ("frame") and of the same frame with each of OPTIONS."""
    import warnings
    out = {"frame": median_ms(lambda: d.deform(P), repeats)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the twist may fold the corrected lattice: the check is what is timed
        for name, kw in OPTIONS:
            out[name] = median_ms(lambda: d.deform(P, **kw), repeats)
    return out


def default_meshes(include_shared: bool = True) -> list:
    # The icospheres match the paper's Sphere and the sizes of the Blender reference in the README.
    out = [("icosphere (2,562 v)", lambda: shapes.icosphere(4)), ("icosphere (40,962 v)", lambda: shapes.icosphere(6)),
           ("icosphere (655,362 v)", lambda: shapes.icosphere(8))]
    if include_shared and SHARED_MESHES.is_dir():
        for f in ["bunny_watertight.ply", "armadillo.ply", "horse.ply", "dragon_vrip_welded.ply.gz"]:
            p = SHARED_MESHES / f
            if p.exists():
                out.append((f.split(".")[0], lambda p=p: load_mesh(p)))
    return out


def format_table(rows: list) -> str:
    head = ("| mesh | vertices | backend | threads | method | FFD ms | 1 axis ms | xyz frame ms | xyz / FFD | "
            "volume error | bytes/vertex | paper matrix nnz |")
    lines = [head, "|" + "---|" * 12]
    for r in rows:
        nnz = f"{r['csr_nnz']:,}" if r["csr_nnz"] else ""
        lines.append(f"| {r['mesh']} | {r['vertices']:,} | {r['backend']} | {r['threads']} | {r['method']} | "
                     f"{r['ffd_ms']:.2f} | {r['one_axis_ms']:.2f} | {r['xyz_ms']:.2f} | "
                     f"{r['xyz_ms'] / r['ffd_ms']:.1f} | {r['volume_error']:.1e} | "
                     f"{r['bytes_per_vertex']:.0f} | {nnz} |")
    return "\n".join(lines)


def format_breakdown(rows: list) -> str:
    """Where an xyz frame's time goes: ms per pass (medians of the frame's own clocks)."""
    lines = ["| mesh | threads | method | " + " | ".join(PASSES) + " | total | frame / FFD |",
             "|" + "---|" * (len(PASSES) + 5)]
    for r in rows:
        b = r["breakdown_ms"]
        lines.append(f"| {r['mesh']} | {r['threads']} | {r['method']} | " +
                     " | ".join(f"{b[k]:.2f}" for k in PASSES) +
                     f" | {b['total']:.2f} | {b['total'] / b['ffd']:.1f} |")
    return "\n".join(lines)


def format_options(rows: list) -> str:
    """What each frame option adds to the xyz frame (ms, and as a fraction of the frame)."""
    names = [n for n, _ in OPTIONS]
    lines = ["| mesh | threads | xyz frame ms | " + " | ".join(f"+ {n} ms" for n in names) + " |",
             "|" + "---|" * (len(names) + 3)]
    for r in rows:
        o = r.get("options_ms")
        if not o:
            continue
        lines.append(f"| {r['mesh']} | {r['threads']} | {o['frame']:.2f} | " +
                     " | ".join(f"{o[n] - o['frame']:.2f} ({(o[n] - o['frame']) / o['frame']:.2f}x)" for n in names) +
                     " |")
    return "\n".join(lines)


def run_benchmark(include_shared: bool = True, repeats: int = 7, with_csr: bool = True, out: str | None = None,
                  shape=(10, 10, 10), degree: int = 3, progress=None) -> list:
    """Runs the benchmark, prints the markdown table, optionally writes JSON to ``out``."""
    rows = []
    meshes = default_meshes(include_shared)
    for i, (name, load) in enumerate(meshes):
        if progress:
            progress(i, len(meshes), name)
        rows += bench_mesh(name, load(), shape=shape, degree=degree, repeats=repeats, with_csr=with_csr)
    print(f"vpffd {_core.__version__} CPU benchmark: {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cores, lattice {'x'.join(map(str, shape))} degree {degree}, "
          f"median of {repeats} runs (ms); twist 90 deg + squash 0.6")
    print(format_table(rows))
    print(f"\nWhere an xyz frame goes (ms, medians; load average {load_average()})")
    print(format_breakdown(rows))
    print("\nWhat Deformer.deform's options add to the xyz frame (ms over it, medians; normals=True, "
          "weights=\"auto\", on_fold=\"warn\")")
    print(format_options(rows))
    if out:
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        write_text(out, json.dumps(dict(machine=platform.uname()._asdict(), cores=os.cpu_count(), rows=rows),
                                   indent=1), "benchmark")
    return rows
