"""Foot points and the fitted base on real scans: how many vertices have an exact foot
point, how much the fit shortens the displacements, and whether large edits turn faces
over, for the default decomposition, for the same without the lift of the displacements
that are not height fields (``lift=False``), and for the affine frames on the faired base
(the representation before exact foot points).

    .venv/bin/python bench/python/bench_foot_points.py [--meshes armadillo horse ...]
        [--out bench/results/<machine>/foot_points_<machine>.md]

A face counts as turned over when its deformed normal points against the space map's
image of its rest normal, cof(J) n0 (J of the plain FFD, averaged over its corners):
a 90 degree twist rotates normals by 90 degrees without turning anything.
"""
from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

import vpffd
from vpffd.cli.benchmark import cpu_model

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "data" / "meshes"
FILES = {"armadillo": "armadillo.ply", "horse": "horse.ply", "bunny": "bunny_watertight.ply",
         "dragon": "dragon_vrip_welded.ply.gz"}
EDITS = {"twist 90": lambda P: vpffd.twist(P, 90), "bend 45": lambda P: vpffd.bend(P, 45),
         "squash 60 %": lambda P: vpffd.squash(P, 0.6)}


def turned_faces(rest, deformed, F, J) -> int:
    def fn(V):
        return np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    Jf = J[F].mean(axis=1)
    cof = np.linalg.inv(Jf).transpose(0, 2, 1) * np.linalg.det(Jf)[:, None, None]
    return int(((np.einsum("fij,fj->fi", cof, fn(rest)) * fn(deformed)).sum(1) < 0).sum())


def run(names, out: Path) -> None:
    rows = []
    for name in names:
        mesh = vpffd.load_mesh(SHARED / FILES[name])
        lat = vpffd.Lattice.around(mesh, shape=8)
        plain = vpffd.Deformer(mesh, lat)
        diag = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
        edits = {k: f(lat.control_points) for k, f in EDITS.items()}
        jac = {k: plain.jacobians(P) for k, P in edits.items()}
        for label, kw in [("affine frames, faired base", dict(fit_rounds=0, foot_points="affine")),
                          ("exact, fitted, no lift", dict(lift=False)),
                          ("exact, fitted, lifted (default)", {})]:
            t0 = time.perf_counter()
            mr = vpffd.Multires(mesh, **kw)
            seconds = time.perf_counter() - t0
            md = vpffd.MultiresDeformer(mr, lat, backend="openmp")
            turned, angles = [], []
            for k, P in edits.items():
                r = md.deform(P, preserve_volume=False)
                turned.append(turned_faces(mesh.vertices, r.vertices, mesh.faces, jac[k]))
                own = vpffd.normals.vertex_normals((r.vertices, mesh.faces))
                angles.append(float(vpffd.normals.angles_deg(r.normals, own).mean()))
            exact = int(mr.exact.sum()) if mr.foot_point_mode == "exact" else 0
            rows.append((name, mesh.n_vertices, label, seconds, int(exact), mr.rms_displacement[0] / diag,
                         mr.rms_displacement[-1] / diag, mr.n_lifted, turned, angles))
            print(rows[-1], flush=True)
    load = os.getloadavg()
    lines = [
        "# Foot points and the fitted base on the closed scans",
        "",
        f"One run of `bench/python/bench_foot_points.py` on {cpu_model()} ({os.cpu_count()} cores, shared "
        f"development VM), load average {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} at the end. "
        "8³ cubic lattice around each mesh, no volume correction, OpenMP frames. "
        "Turned: faces whose deformed normal points against cof(J) n0 of the plain FFD "
        "(which turns none in any of these edits). Normal error: mean angle between the "
        "approximate normals and the rebuilt mesh's own area-weighted normals. Lifted: vertices "
        "whose displacement is partly handed to the base deformation (`Multires.lift`).",
        "",
        "| mesh | vertices | decomposition | time s | exact foot points | RMS d / diag faired | "
        "RMS d / diag final | lifted | turned: " + " / ".join(EDITS) + " | normal error ° |",
        "|---|---:|---|---:|---:|---:|---:|---:|---|---|",
    ]
    for name, nv, label, s, ex, d0, d1, lifted, turned, ang in rows:
        lines.append(f"| {name} | {nv:,} | {label} | {s:.1f} | {ex:,} | {d0:.2e} | {d1:.2e} | {lifted:,} | "
                     f"{' / '.join(str(t) for t in turned)} | {' / '.join(f'{a:.2f}' for a in ang)} |")
    lines.append("")
    from vpffd._files import write_text
    write_text(out, "\n".join(lines))
    print("\n".join(lines))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--meshes", nargs="+", default=list(FILES), choices=list(FILES))
    machine = os.environ.get("VPFFD_BENCH_MACHINE") or platform.node() or "host"
    p.add_argument("--out", type=Path, default=ROOT / "bench" / "results" / machine / f"foot_points_{machine}.md")
    a = p.parse_args(argv)
    if not SHARED.is_dir():
        print(f"needs {SHARED}", file=sys.stderr)
        return 2
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)  # a new machine's folder
    run(a.meshes, a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
