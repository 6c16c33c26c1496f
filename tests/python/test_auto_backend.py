"""backend="auto": a GPU only for meshes of AUTO_GPU_MIN_VERTICES or more.

The device list is monkeypatched, so these run on any machine (no Vulkan needed).
"""
import pytest

import vpffd
from vpffd import _core
from vpffd import backends as dm

GPU = dict(index=3, name="Fake GPU", type="discrete", memory_bytes=1 << 34, float64=True, suitable=True, reason="")
SOFT = dict(GPU, index=0, name="llvmpipe", type="cpu")


@pytest.fixture
def fake_devices(monkeypatch):
    calls = []

    def devices(which):
        def listing():
            calls.append(1)
            return [dict(d) for d in which]
        monkeypatch.setattr(dm, "vulkan_devices", listing)
        return calls

    monkeypatch.setattr(_core, "has_vulkan", True, raising=False)
    monkeypatch.delenv("VPFFD_VULKAN_DEVICE", raising=False)
    return devices


def test_threshold_rule(fake_devices):
    calls = fake_devices([SOFT, GPU])
    n = dm.AUTO_GPU_MIN_VERTICES
    assert n == 20_000
    cpu = "openmp" if _core.has_openmp() and dm.os.cpu_count() > 1 else "serial"
    assert dm._resolve_backend("auto", None, None, n - 1)[0] == cpu
    assert calls == []  # a small mesh does not even start Vulkan
    assert dm._resolve_backend("auto", None, None, n)[::2] == ("vulkan", "3")
    assert dm._resolve_backend("auto", None, None, None)[::2] == ("vulkan", "3")
    # Explicit choices do not depend on the size.
    assert dm._resolve_backend("vulkan", None, None, 10)[0] == "vulkan"
    assert dm._resolve_backend("auto", None, "llvmpipe", 10)[::2] == ("vulkan", "llvmpipe")
    assert dm._resolve_backend("serial", None, None, 10 ** 7)[0] == "serial"


def test_threshold_env_and_software(fake_devices, monkeypatch):
    fake_devices([SOFT])
    n = dm.AUTO_GPU_MIN_VERTICES
    assert dm._resolve_backend("auto", None, None, 10 * n)[0] != "vulkan"  # software devices only when named
    monkeypatch.setenv("VPFFD_VULKAN_DEVICE", "0")
    assert dm._resolve_backend("auto", None, None, 10)[::2] == ("vulkan", "0")


def test_small_mesh_deformer_stays_on_cpu(fake_devices):
    calls = fake_devices([GPU])
    mesh = vpffd.shapes.icosphere(2)
    assert mesh.n_vertices < dm.AUTO_GPU_MIN_VERTICES
    d = vpffd.Deformer(mesh, vpffd.Lattice.around(mesh, shape=4))
    assert d.backend in ("openmp", "serial") and calls == []
