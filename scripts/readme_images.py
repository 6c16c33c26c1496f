#!/usr/bin/env python
"""Writes docs/images/comparison.png, the README's picture of a deformation:
a pear-like figure built in code (y up), squashed to 60 % along y, the volume
correction allowed along x and z only (as `vpffd deform IN OUT --squash 0.6
--preserve xz --render PNG` draws it); docs/images/shoal.png and
mobius_walk.png, a frame of each of the demo's moving-object scenes; and
docs/images/multires.png, the last frame of the demo's multiresolution scene.

    .venv/bin/python scripts/readme_images.py [--out docs/images]
"""
import argparse
from pathlib import Path

import vpffd
from vpffd._figure import figure


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "images"))
    a = ap.parse_args()
    mesh = figure(5)
    lat = vpffd.Lattice.around(mesh, shape=(6, 6, 6), degree=3)
    d = vpffd.Deformer(mesh, lat)
    up, why = vpffd.guess_up_axis(mesh)
    r = d.deform(vpffd.edits.squash(lat.control_points, 0.6, axis=up), axes="xz")
    img = vpffd.render_comparison(d, r, size=(1600, 600), up=up, lattice_style="faint")
    out = Path(a.out) / "comparison.png"
    vpffd.save_png(out, img)
    print(f"up {up} ({why}); plain FFD {100 * r.volume_change_before:+.2f} %, preserved error "
          f"{r.volume_error:.1e}; wrote {out}")
    import shutil
    import tempfile

    from vpffd.cli import motion
    for make, frame in ((motion.shoal, 17), (motion.mobius_walk, 4)):
        scene = motion.run_motion(make())
        with tempfile.TemporaryDirectory() as tmp:
            motion.render(scene, Path(tmp), (480, 360))
            dest = Path(a.out) / f"{scene.key}.png"
            shutil.copy(Path(tmp) / scene.key / f"frame_{frame:03d}.png", dest)
        print(f"wrote {dest}")
    from vpffd.cli import multires_scene
    scene = multires_scene.run(multires_scene.bent_body())
    with tempfile.TemporaryDirectory() as tmp:
        multires_scene.render(scene, Path(tmp), (400, 300))
        dest = Path(a.out) / "multires.png"
        shutil.copy(Path(tmp) / scene.key / f"frame_{scene.frames - 1:03d}.png", dest)
    print(f"wrote {dest}")


if __name__ == "__main__":
    main()
