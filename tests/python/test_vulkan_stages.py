"""The host's stages of a Vulkan frame in last_timings (what bench_gpu.py prints): each
is there, none is negative, and they nest (the stages within the core's call, the
core's call within the Python call). No time is asserted: speed belongs to bench/."""
import pytest

import vpffd
from vpffd import edits, shapes

from test_vulkan import DEVICE, SEL

pytestmark = pytest.mark.skipif(DEVICE is None, reason="no Vulkan backend in this build or no suitable device")


def test_host_stages_nest():
    mesh = shapes.icosphere(3)
    lat = vpffd.Lattice.around(mesh, shape=(5, 5, 5), degree=3)
    d = vpffd.Deformer(mesh, lat, backend="vulkan", device=SEL)
    for kw in (dict(), dict(preserve_volume=False), dict(normals=True)):
        d.deform(edits.squash(lat.control_points, 0.8), **kw)
        t = d.last_timings()
        stages = [t[k] for k in ("host_prepare_ms", "host_submit_wait_ms", "host_unpack_ms")]
        assert all(s >= 0 for s in stages), t
        assert sum(stages) <= t["host_total_ms"] <= t["python_total_ms"], t
        if t["has_timestamps"]:
            assert t["gpu_total_ms"] >= 0
