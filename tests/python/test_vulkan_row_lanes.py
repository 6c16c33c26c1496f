"""combine.comp sums each control point's tile partials with LANES invocations per row:
a workgroup's 64 on a GPU (a row of a large mesh has thousands of tiles), one on a CPU
device (lavapipe, where a workgroup's invocations run in turn and barriers are dear).
CI has lavapipe only, so VPFFD_VULKAN_ROW_LANES makes the backend take every lane count
here. Each frame is checked against the CPU within the device's bounds (gpu_bounds.py:
the lane count changes only the order of the coefficient sums, whose rounding those
bounds already cover), on a plain lattice, a periodic one (each distinct control point
sums the tiles of its extended copies) and with parts (one row per part), on meshes
with several tiles per cell so that the lanes really split a row; reruns are
bit-identical for every lane count."""
import numpy as np
import pytest

import vpffd
from vpffd import edits, shapes
from gpu_bounds import check_frame
from test_vulkan import DEVICE, edit, gpu_deformer
from test_vulkan import precision  # noqa: F401 (the fixture: both precisions, float64 where the device has it)
from test_vulkan_parts import spheres

pytestmark = pytest.mark.skipif(DEVICE is None, reason="no Vulkan backend in this build or no suitable device")


def case(name):
    """(mesh, lattice, control points, Deformer keywords) of a frame whose cells hold
    several 64-vertex tiles each."""
    if name == "plain":
        mesh = shapes.icosphere(4)  # 2,562 vertices in 2^3 cells: ~5 tiles a cell
        lat = vpffd.Lattice.around(mesh, shape=5)
        return mesh, lat, edit(lat), {}
    if name == "periodic":
        lat = vpffd.Lattice([-1.0, -0.5, -0.4], [2.0, 0.5, 0.4], shape=(7, 5, 4), periodic="x", seam="closed")
        s = shapes.icosphere(4, 0.3)
        mesh = vpffd.Mesh(s.vertices + [1.85, 0.0, 0.0], s.faces)  # across the seam
        return mesh, lat, edits.ring(lat, radius=0.8, axis="x", around="z"), {}
    mesh, labels = spheres(2, subdivisions=4)
    lat = vpffd.Lattice.around(mesh, shape=(6, 4, 4))
    P = edits.squash(edits.twist(lat.control_points, np.pi / 2, axis="z"), 0.7, axis="z")
    return mesh, lat, P, dict(parts=labels)


@pytest.mark.parametrize("lanes", ["1", "2", "64"])
@pytest.mark.parametrize("name", ["plain", "periodic", "parts"])
def test_every_lane_count_matches_the_cpu(monkeypatch, precision, lanes, name):
    monkeypatch.setenv("VPFFD_VULKAN_ROW_LANES", lanes)
    mesh, lat, P, kw = case(name)
    g = gpu_deformer(mesh, lat, precision, **kw)
    c = vpffd.Deformer(mesh, lat, backend="serial", **kw)
    rg, rc = g.deform(P), c.deform(P)
    check_frame(rg, rc, mesh, lat, cpu=c)
    again = g.deform(P)
    assert np.array_equal(again.vertices, rg.vertices) and np.array_equal(again.offsets, rg.offsets)


def test_bad_lane_counts_are_refused(monkeypatch, precision):
    mesh = shapes.icosphere(1)
    lat = vpffd.Lattice.around(mesh, shape=4)
    for bad in ("3", "0", "128", "x", "8x"):
        monkeypatch.setenv("VPFFD_VULKAN_ROW_LANES", bad)
        with pytest.raises(vpffd.InvalidInputError, match="VPFFD_VULKAN_ROW_LANES"):
            gpu_deformer(mesh, lat, precision)
