#!/usr/bin/env python
"""vpffd against Blender's Lattice modifier, interleaved in one run on one machine.

    .venv/bin/python bench/python/bench_peers.py --install-peers   # once: ./.venv-peers with bpy (~1 GB)
    .venv/bin/python bench/python/bench_peers.py [--rounds 5] [--repeats 7] [--cpus 0,1] [--no-shared]

What is compared, per mesh (icospheres of 2,562 / 40,962 / 655,362 vertices made in
code, and the Stanford dragon from ../shared/data/meshes when it is there):
  - Blender: the Lattice modifier of a 10x10x10 lattice with B-spline interpolation on
    all three axes over the same box, its points twisted 90 degrees about z; the time
    of re-evaluating the mesh object (its modifier stack) through the depsgraph.
    Blender runs in its own process (the peers environment's Python 3.11 with the
    ``bpy`` wheel, driven by _blender_lattice.py); "Blender base" is the same
    evaluation with the modifier disabled (what the evaluation costs without it).
  - vpffd: ``Deformer.ffd(P)`` (plain FFD) and ``Deformer.deform(P, axes="xyz")``
    (the volume-preserving frame) with the same box, 10^3 cubic lattice and twist,
    on 2 threads and on 1.
Both processes are pinned to the same CPUs (--cpus, default the first two this
process may use), so each side has exactly those cores; the rounds alternate
Blender and vpffd so that a change in machine load hits both. The table's times are
medians over all rounds; its ratios are the median (and range) of each round's own
ratio, both sides of a round measured seconds apart, which is steadier than a ratio
of medians when the machine's speed drifts. The load average is printed before and
after.

The two lattices are not the same function: Blender's B-spline lattice is uniform
with its end points repeated, vpffd's is clamped (open-uniform), so the deformed
shapes differ slightly; the work per vertex is the same (64 control points).

Results: bench/results/<machine>/peers_<machine>.json and .csv (machine: $VPFFD_BENCH_MACHINE,
else the host name). Without ./.venv-peers (and
without --install-peers) only the vpffd columns are measured.

PyGeM (mathLab's FFD in Python) is not measured: it is not on PyPI, where the name
``pygem`` is a glacier model (every release, 0.2.0 to 1.0.4, checked 2026-11-28), and
this machine reaches PyPI and Debian only.
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
PEERS = ROOT / ".venv-peers"
DRIVER = Path(__file__).resolve().parent / "_blender_lattice.py"
SHAPE = (10, 10, 10)
ANGLE = 90.0


def install_peers(python: str) -> None:
    """Creates ./.venv-peers with ``python`` (Blender's wheels need 3.11) and installs bpy 5.0.x."""
    if not (PEERS / "bin" / "python").exists():
        subprocess.run([python, "-m", "venv", str(PEERS)], check=True)
    pip = [str(PEERS / "bin" / "python"), "-m", "pip", "install"]
    for spec in ("bpy==5.0.*", "bpy>=5,<5.1", "bpy>=4,<5"):
        if subprocess.run(pip + [spec]).returncode == 0:
            print(f"installed {spec} into {PEERS}")
            return
    raise SystemExit("could not install bpy into .venv-peers (needs Python 3.11 and network access to PyPI)")


class Blender:
    """One Blender process holding one mesh, lattice and modifier."""

    def __init__(self, npz: Path, cpus: list):
        self.p = subprocess.Popen([str(PEERS / "bin" / "python"), str(DRIVER), str(npz), ",".join(map(str, cpus))],
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        self.info = self._read()

    def _read(self) -> dict:
        while True:
            line = self.p.stdout.readline()
            if not line:
                raise RuntimeError("the Blender process ended early (see its output above)")
            if line.startswith("{"):  # bpy may print its own lines first
                return json.loads(line)

    def time(self, repeats: int) -> dict:
        self.p.stdin.write(f"time {repeats}\n")
        self.p.stdin.flush()
        return self._read()

    def close(self):
        try:
            self.p.stdin.write("quit\n")
            self.p.stdin.close()
        except (BrokenPipeError, OSError):
            pass
        self.p.wait(timeout=60)


def samples_ms(fn, repeats: int) -> list:
    fn()  # warm-up
    out = []
    for _ in range(repeats):
        s = time.perf_counter()
        fn()
        out.append(1e3 * (time.perf_counter() - s))
    return out


def meshes(include_shared: bool):
    from vpffd import shapes
    from vpffd.cli.benchmark import SHARED_MESHES
    from vpffd.io import load_mesh
    out = [(f"icosphere {n:,} v", lambda s=s: shapes.icosphere(s)) for s, n in ((4, 2562), (6, 40962), (8, 655362))]
    dragon = SHARED_MESHES / "dragon_vrip_welded.ply.gz"
    if include_shared and dragon.exists():
        out.insert(2, ("dragon 435,545 v", lambda: load_mesh(dragon)))
    return out


def blender_points(box_min, box_max):
    """Blender's rest lattice points in world space (u fastest), twisted like vpffd's."""
    from vpffd import edits
    g = np.stack(np.meshgrid(*[np.linspace(box_min[a], box_max[a], SHAPE[a]) for a in range(3)], indexing="ij"),
                 axis=-1)
    return edits.twist(g.transpose(2, 1, 0, 3).reshape(-1, 3), ANGLE)


def bench_mesh(name, mesh, args, cpus, tmp: Path, use_blender: bool) -> dict:
    from vpffd import Deformer, Lattice, edits
    lat = Lattice.around(mesh, shape=SHAPE, degree=3, padding=0.05)
    P = edits.twist(lat.control_points, ANGLE)
    d2 = Deformer(mesh, lat, backend="openmp", threads=2)
    d1 = Deformer(mesh, lat, backend="openmp", threads=1)
    r = d2.deform(P, axes="xyz")
    row = dict(mesh=name, vertices=mesh.n_vertices, faces=mesh.n_faces, volume_error=r.volume_error)
    t = {k: [] for k in ("blender_ms", "blender_base_ms", "ffd2_ms", "vp2_ms", "ffd1_ms", "vp1_ms")}
    blender = None
    if use_blender:
        npz = tmp / "mesh.npz"
        np.savez(npz, V=mesh.vertices, F=mesh.faces, box_min=lat.box_min, box_max=lat.box_max,
                 shape=np.array(SHAPE), edited_points=blender_points(lat.box_min, lat.box_max))
        blender = Blender(npz, cpus)
        if not blender.info["moved"] > 0:
            raise RuntimeError(f"{name}: Blender's modifier did not move the mesh")
        row["blender_version"] = blender.info["version"]
        row["blender_threads_in_process"] = blender.info["threads_in_process"]
    rounds = []  # each round's samples, for the paired ratios
    try:
        for _ in range(args.rounds):
            r = {k: [] for k in t}
            if blender:
                b = blender.time(args.repeats)
                r["blender_ms"] = b["modifier_ms"]
                r["blender_base_ms"] = b["base_ms"]
            r["ffd2_ms"] = samples_ms(lambda: d2.ffd(P), args.repeats)
            r["vp2_ms"] = samples_ms(lambda: d2.deform(P, axes="xyz"), args.repeats)
            r["ffd1_ms"] = samples_ms(lambda: d1.ffd(P), args.repeats)
            r["vp1_ms"] = samples_ms(lambda: d1.deform(P, axes="xyz"), args.repeats)
            rounds.append(r)
            for k in t:
                t[k] += r[k]
    finally:
        if blender:
            blender.close()
    for k, v in t.items():
        row[k] = float(np.median(v)) if v else None
        row[k.replace("_ms", "_samples")] = len(v)
    for num, den in PAIRED:
        row[f"{num}_over_{den}_rounds"] = round_ratios(rounds, num + "_ms", den + "_ms")
    return row


# The ratios each round gives (numerator, denominator): a round's two sides run
# seconds apart, so a change in the machine's speed between rounds (other tenants of
# a VM) moves both; the median of these ratios is steadier than a ratio of medians.
PAIRED = (("vp2", "blender"), ("vp1", "blender"), ("vp2", "ffd2"))


def round_ratios(rounds, num: str, den: str) -> list:
    """Per round, the median of `num`'s samples over the median of `den`'s; rounds
    where either side has no samples are left out."""
    return [float(np.median(r[num]) / np.median(r[den])) for r in rounds if r.get(num) and r.get(den)]


def paired(row, num: str, den: str) -> str:
    """The median of the rounds' ratios with their range, e.g. "0.74 (0.70-0.81)";
    "n/a" without rounds."""
    x = row.get(f"{num}_over_{den}_rounds") or []
    if not x:
        return "n/a"
    return f"{np.median(x):.2f} ({min(x):.2f}-{max(x):.2f})" if len(x) > 1 else f"{x[0]:.2f}"


def ms(x):
    return f"{x:.2f}" if x is not None else "n/a"


def format_table(rows) -> str:
    """The results as a Markdown table: times are medians of all samples, ratios the
    median (and range) of each round's ratio (round_ratios)."""
    lines = ["| mesh | Blender modifier (2 thr) | Blender base | vpffd FFD | vpffd VP xyz | VP / Blender | "
             "VP / own FFD | vpffd FFD 1 thr | VP xyz 1 thr | VP 1 thr / Blender 2 thr |",
             "|---|" + "---:|" * 9]
    for r in rows:
        lines.append(f"| {r['mesh']} | {ms(r['blender_ms'])} | {ms(r['blender_base_ms'])} | {ms(r['ffd2_ms'])} | "
                     f"{ms(r['vp2_ms'])} | {paired(r, 'vp2', 'blender')} | {paired(r, 'vp2', 'ffd2')} | "
                     f"{ms(r['ffd1_ms'])} | {ms(r['vp1_ms'])} | {paired(r, 'vp1', 'blender')} |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--install-peers", action="store_true", help="create ./.venv-peers and install bpy 5.0.x first")
    ap.add_argument("--python", default="python3.11", help="interpreter for .venv-peers (bpy needs 3.11)")
    ap.add_argument("--rounds", type=int, default=5, help="alternations of Blender and vpffd per mesh")
    ap.add_argument("--repeats", type=int, default=7, help="timed runs per side and round")
    ap.add_argument("--cpus", default=None, help="CPUs both sides run on, e.g. 0,1 (default: the first two)")
    ap.add_argument("--no-shared", action="store_true", help="only the generated icospheres")
    ap.add_argument("--no-blender", action="store_true", help="only vpffd")
    machine = os.environ.get("VPFFD_BENCH_MACHINE") or platform.node() or "host"
    ap.add_argument("--out", default=str(ROOT / "bench" / "results" / machine / f"peers_{machine}"),
                    help="results path without extension (.json and .csv are written)")
    args = ap.parse_args()
    if args.install_peers:
        install_peers(args.python)
    allowed = sorted(os.sched_getaffinity(0))
    cpus = [int(c) for c in args.cpus.split(",")] if args.cpus else allowed[:2]
    os.sched_setaffinity(0, cpus)  # before vpffd starts its OpenMP threads
    use_blender = not args.no_blender and (PEERS / "bin" / "python").exists()
    if not use_blender and not args.no_blender:
        print(f"no {PEERS} (run with --install-peers): measuring vpffd only", file=sys.stderr)

    import vpffd
    from vpffd.cli.benchmark import cpu_model, load_average
    head = dict(machine=platform.node(), cpu=cpu_model(), cores_online=os.cpu_count(), cpus=cpus,
                vpffd=vpffd.__version__, python=platform.python_version(), rounds=args.rounds,
                repeats=args.repeats, lattice="x".join(map(str, SHAPE)) + " cubic B-spline", edit=f"twist {ANGLE:g} deg",
                load_before=load_average())
    print(f"{head['cpu']}, {len(cpus)} CPUs ({','.join(map(str, cpus))}) of {os.cpu_count()}; "
          f"load average before: {head['load_before']}", flush=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, load in meshes(not args.no_shared):
            rows.append(bench_mesh(name, load(), args, cpus, Path(tmp), use_blender))
            print(f"  {name}: done (load {load_average()})", flush=True)
    head["load_after"] = load_average()
    version = next((r.get("blender_version") for r in rows if r.get("blender_version")), None)
    head["blender"] = version
    print(f"\nvpffd {head['vpffd']} vs Blender {version or '(not run)'} Lattice modifier; {head['lattice']}, "
          f"{head['edit']}; medians of {args.rounds} rounds x {args.repeats} runs (ms); ratios: the median (range) "
          f"of each round's ratio; 2 threads unless stated")
    print(format_table(rows))
    print(f"\nmachine: {head['cpu']}, pinned to CPUs {cpus}; load average before {head['load_before']}, "
          f"after {head['load_after']}")
    from vpffd._files import open_replacing, write_text  # checked writes: a failure leaves the old file
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)  # a new machine's folder
    out.parent.mkdir(parents=True, exist_ok=True)
    write_text(out.with_suffix(".json"), json.dumps(dict(head, rows=rows), indent=1))
    keys = list(rows[0].keys()) if rows else []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with open_replacing(out.with_suffix(".csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows({k: " ".join(f"{x:.4f}" for x in v) if isinstance(v, list) else v for k, v in r.items()}
                    for r in rows)
    print(f"wrote {out.with_suffix('.json')} and .csv")


if __name__ == "__main__":
    main()
