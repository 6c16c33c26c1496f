#!/usr/bin/env python
"""Writes docs/images/ring.png, mobius.png and terrain.png, the README's pictures of
shaped lattices (vpffd.edits.ring, mobius, terrain), each with its (extended)
control net, and prints the volume each keeps.

    .venv/bin/python scripts/lattice_shape_images.py [--out docs/images]

Needs the Embree renderer (vpffd.render).
"""
import argparse
from pathlib import Path

import numpy as np

import vpffd


def _join(*meshes):
    """One mesh of several (vertices stacked, faces renumbered)."""
    V, F, off = [], [], 0
    for m in meshes:
        V.append(m.vertices)
        F.append(m.faces + off)
        off += m.n_vertices
    return vpffd.Mesh(np.concatenate(V), np.concatenate(F))


def _slab(lo, hi, n):
    """A closed box mesh filling [lo, hi] (n x n squares a side, before the stretch)."""
    m = vpffd.shapes.box(n, 1.0)
    return vpffd.Mesh(np.asarray(lo) + (m.vertices + 0.5) * (np.asarray(hi) - np.asarray(lo)), m.faces)


def ring_picture(size):
    # Whales (fish-like ellipsoids) in a straight periodic box, bent into a ring.
    lat = vpffd.Lattice([0, -0.6, -0.3], [12, 0.6, 0.3], shape=(16, 4, 4), periodic="x", seam="closed")
    fish = vpffd.shapes.icosphere(3, 1.0)
    whales = _join(*[vpffd.Mesh(fish.vertices * [0.9, 0.25, 0.2] + [x, 0.15 * (-1) ** i, 0], fish.faces)
                     for i, x in enumerate(np.arange(1.0, 12.0, 2.0))])
    d = vpffd.Deformer(whales, lat)
    r = d.deform(vpffd.edits.ring(lat))
    cam = vpffd.Camera.framing(np.concatenate([r.vertices, lat.expanded_control_points(r.control_points)
                                               .reshape(-1, 3)]), size=size)
    img = vpffd.render(vpffd.Mesh(r.vertices, whales.faces), camera=cam, lattice=lat,
                       control_points=r.control_points, size=size)
    return img, r


def mobius_picture(size):
    # A thin band (ants would walk on it), the lattice twisted half a turn per lap.
    lat = vpffd.Lattice([0, -0.5, -0.06], [2 * np.pi, 0.5, 0.06], shape=(24, 4, 3), degree=(3, 3, 2),
                        periodic="x", seam="twist")
    band = _slab([0.0, -0.4, -0.04], [2 * np.pi * 0.999, 0.4, 0.04], 24)
    d = vpffd.Deformer(band, lat)
    r = d.deform(vpffd.edits.mobius(lat, radius=1.0))
    img = vpffd.render(vpffd.Mesh(r.vertices, band.faces), lattice=lat, control_points=r.control_points,
                       size=size, lines=False)
    return img, r


def terrain_picture(size):
    # A slab of ground and a box "car" in one lattice laid over rolling hills.
    lat = vpffd.Lattice([0, 0, 0], [8, 4, 1.2], shape=(12, 7, 3), degree=(3, 3, 2))
    hills = lambda x, y: 0.5 * np.sin(0.9 * x) * np.cos(0.8 * y)  # noqa: E731
    ground = _slab([0.05, 0.05, 0.05], [7.95, 3.95, 0.3], 16)
    car = _slab([3.0, 1.6, 0.35], [4.2, 2.4, 0.8], 6)
    scene = _join(ground, car)
    d = vpffd.Deformer(scene, lat)
    r = d.deform(vpffd.edits.terrain(lat, hills))
    img = vpffd.render(vpffd.Mesh(r.vertices, scene.faces), lattice=lat, control_points=r.control_points,
                       size=size)
    return img, r


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "images"))
    ap.add_argument("--size", type=int, nargs=2, default=(640, 480))
    a = ap.parse_args()
    for name, make in (("ring", ring_picture), ("mobius", mobius_picture), ("terrain", terrain_picture)):
        img, r = make(tuple(a.size))
        out = Path(a.out) / f"{name}.png"
        vpffd.save_png(out, img)
        print(f"{name}: plain FFD {100 * r.volume_change_before:+.2f} % volume, corrected error "
              f"{r.volume_error:.1e}; wrote {out}")


if __name__ == "__main__":
    main()
