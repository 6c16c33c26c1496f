"""Which backend runs a Deformer: the CPU ("serial", "openmp") or a Vulkan device,
and what backend="auto" picks (the device list, the size threshold, the precision)."""
from __future__ import annotations

import os

import numpy as np

from . import _core

InvalidInputError = _core.InvalidInputError
BackendUnavailableError = _core.BackendUnavailableError

_CPU_BACKENDS = ("serial", "openmp")
_VULKAN_ENV = "VPFFD_VULKAN_DEVICE"
_PRECISION_ENV = "VPFFD_VULKAN_PRECISION"
_PRECISIONS = ("auto", "float64", "float-float")
_TYPE_RANK = {"discrete": 0, "integrated": 1, "virtual": 2, "other": 3, "cpu": 4}
# backend="auto" takes a GPU from this many vertices on. A GPU frame has a fixed
# cost the CPU does not: one submission and fence wait, ~4 dispatches per axis step
# with barriers, the vertex read-back and its reordering to the input order, about
# 0.3-1 ms in all; the CPU's xyz frame costs about 0.1 us per vertex here (2 cores:
# 0.9 ms for 10k vertices, 5 ms for 43k), less on a many-core machine. Below ~20k
# vertices the GPU cannot win by much, and the device start-up (instance, device,
# shader compilation: 50-200 ms) is not worth paying. Naming a device
# (device= or VPFFD_VULKAN_DEVICE) takes it whatever the size.
AUTO_GPU_MIN_VERTICES = 20_000


def vulkan_devices() -> list:
    """The Vulkan devices, one dict each: ``index``, ``name``, ``type`` ("discrete",
    "integrated", "virtual", "cpu" for a software device such as lavapipe, or
    "other"), ``memory_bytes`` (largest device-local heap), ``api_version``,
    ``driver``, ``float64`` (shaderFloat64; without it the sums are float-float),
    ``suitable`` and, when not, ``reason``.
    Empty when this build has no Vulkan backend or there is no loader or driver."""
    if not _core.has_vulkan:
        return []
    devices, _why = _core.vulkan_devices()
    return list(devices)


def _hardware_vulkan_device():
    """Index (as a string) of the best suitable non-software device, or None."""
    ok = [d for d in vulkan_devices() if d["suitable"] and d["type"] != "cpu"]
    ok.sort(key=lambda d: _TYPE_RANK.get(d["type"], 3))
    return str(ok[0]["index"]) if ok else None


def available_backends(devices=None) -> list:
    """Backends this build can run here, best first for ``backend='auto'``.
    "vulkan" comes first with a GPU, last when the only device is a software one
    (which ``auto`` does not take unless VPFFD_VULKAN_DEVICE names it).
    ``devices``: a ``vulkan_devices()`` list already at hand (default: listed now)."""
    out = []
    if _core.has_openmp():
        out.append("openmp")
    out.append("serial")
    devices = [d for d in (vulkan_devices() if devices is None else devices) if d["suitable"]]
    if any(d["type"] != "cpu" for d in devices):
        out.insert(0, "vulkan")
    elif devices:
        out.append("vulkan")
    return out


def _requested_precision(gpu_precision=None) -> str:
    """The GPU precision asked for: the argument, else VPFFD_VULKAN_PRECISION, else "auto"."""
    precision = gpu_precision if gpu_precision is not None else os.environ.get(_PRECISION_ENV) or "auto"
    if precision not in _PRECISIONS:
        where = "gpu_precision" if gpu_precision is not None else _PRECISION_ENV
        raise InvalidInputError(f"{where}: expected one of {', '.join(map(repr, _PRECISIONS))}, got {precision!r}")
    return precision


def _resolve_backend(backend: str, threads, device=None, n_vertices=None):
    """(backend, threads for the CPU core, Vulkan device selector or None).
    ``n_vertices``: the mesh size "auto" weighs (None: any size)."""
    if not isinstance(backend, str):
        raise TypeError(f"backend: expected a string, got {type(backend).__name__}")
    if device is not None and not isinstance(device, (str, int, np.integer)) or isinstance(device, bool):
        raise TypeError(f"device: expected a device index or name, got {type(device).__name__}")
    selector = None if device is None else str(device)
    env = os.environ.get(_VULKAN_ENV) or None
    if backend == "auto":
        # A GPU when there is one and the mesh is large enough (size first: listing the
        # devices starts Vulkan); a software device only when named.
        large = n_vertices is None or n_vertices >= AUTO_GPU_MIN_VERTICES
        has_vulkan = _core.has_vulkan
        gpu = _hardware_vulkan_device() if has_vulkan and large and not (selector or env) else None
        if has_vulkan and (selector or env):
            backend = "vulkan"
        elif gpu is not None:
            backend, selector = "vulkan", gpu
        else:
            backend = "openmp" if _core.has_openmp() and (os.cpu_count() or 1) > 1 else "serial"
    if backend not in (*_CPU_BACKENDS, "vulkan"):
        known = ", ".join(repr(b) for b in ("auto", *_CPU_BACKENDS, "vulkan"))
        raise InvalidInputError(f"backend: unknown backend {backend!r}; known: {known}")
    if backend == "openmp" and not _core.has_openmp():
        raise BackendUnavailableError("backend 'openmp': this build has no OpenMP")
    if backend == "vulkan" and not _core.has_vulkan:
        raise BackendUnavailableError("backend 'vulkan': this build has no Vulkan backend (it needs libvulkan-dev, "
                                      "glslc and libvulkan-volk-dev at build time)")
    if backend != "vulkan" and selector is not None:
        raise InvalidInputError(f"device: only the 'vulkan' backend takes a device, not {backend!r}")
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, (int, np.integer))
                                or not 1 <= threads <= 4096):
        raise InvalidInputError(f"threads: expected an integer in 1..4096 or None, got {threads!r}")
    n = 1 if backend == "serial" else int(threads or 0)
    if backend == "vulkan" and selector is None:
        selector = env or ""
    return backend, n, selector
