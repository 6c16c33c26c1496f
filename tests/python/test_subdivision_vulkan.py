"""The displaced-subdivision-surface frame on the Vulkan device (shaders/subdiv.comp,
_core.VulkanSubdivFrame, ``SubdivisionMultires.deform(backend="vulkan")``) against the
CPU frame (subdiv/subdivision_frame.h), within per-vertex bounds derived below from
the device's float32 arithmetic; runs on lavapipe (a CPU Vulkan driver), in both
precisions (float64 and float-float stencil sums), on a bumpy sphere and a torus with
Loop and Catmull-Clark.

The derivation (subdiv_bounds), in device units y = (x - o) / s (o the rest control
points' box centre, s a power of two, so the scaling is exact), u = 2^-24:

- each control point is rounded to float32: |dy_j| <= u |y_j| per component;
- S' = sum_j w_j y_j is formed in reals (float64: 2^-53 per operation; float-float:
  about 2^-44) over the vertex's n entries: at most (n + 2) 2^-40 sum_j |w_j||y_j|;
- S' is rounded once to float32: u |S'| <= u sum_j |w_j||y_j|.
  So |S'_dev - S'| <= e_S = (2u + (n + 2) 2^-40) A with A = |sum_j |w_j| |y_j||
  (componentwise sums, then the vector norm), and S'_u, S'_v likewise with w_u, w_v.
- c = S'_u x S'_v in float32: the input errors give e_su |S'_v| + |S'_u| e_sv +
  e_su e_sv, its own roundings at most 4u (|S'_u| + e_su)(|S'_v| + e_sv); the unit
  normal's error is then at most 2 e_c / |c| + 4u (normalisation included), and 2 when
  e_c >= |c| (no bound on the direction).
- p' = S' + d N_S' (d rounded to float32, a product and a sum): e_S + |d| e_N + 3u |d|
  + u (|S'| + |d|), plus 2^-40 of the size for the CPU's own double rounding and the
  host's conversions.
- the approximate normal: f = a S'_u + b S'_v + g N_S' (a, b times s, g as they are,
  all rounded to float32) has error |a| e_su + |b| e_sv + |g| e_N + 4u (|a| (|S'_u| +
  e_su) + |b| (|S'_v| + e_sv) + |g|); the cross of f_u and f_v as above; the angle is at
  most asin(e_n / |f_u x f_v|) + 4u.
Everything is multiplied by 1.01 for the second-order terms left out. The bound holds
on any driver that rounds float32 addition and multiplication correctly (Vulkan's
promise); it is the same analysis as gpu_bounds.multires_bounds, with the stencil
sums in place of the B-spline tensor sums.
"""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import vpffd
from vpffd.normals import angles_deg
from test_subdivision import CASES, decomposition, needs_osd
from test_vulkan import DEVICE, SEL
from test_vulkan import precision  # noqa: F401 (the fixture: both precisions, float64 where the device has it)

pytestmark = [pytest.mark.skipif(DEVICE is None, reason="no Vulkan backend in this build or no suitable device"),
              needs_osd]

U32 = 2.0 ** -24


def _norm(x):
    return np.linalg.norm(x, axis=1)


def subdiv_bounds(sm, frame, C):
    """Per vertex ((V,) world units, (V,) world units, (V,) degrees): bounds on the
    distance between the device's and the CPU's vertices p', limit points S', and the
    angle between their approximate normals, for control points C (M, 3); ``frame``
    gives the device units (origin, scale). The derivation is the module's docstring."""
    st = sm.stencils()
    V = sm.n_vertices
    n = np.diff(st["indptr"]).astype(float)
    rows = np.repeat(np.arange(V), np.diff(st["indptr"]))
    o, s = np.asarray(frame.origin, float), float(frame.scale)
    y = (np.asarray(C, float) - o) / s
    yj, ayj = y[st["indices"]], np.abs(y[st["indices"]])

    def stencil_sum(w):
        ref, A = np.zeros((V, 3)), np.zeros((V, 3))
        np.add.at(ref, rows, w[:, None] * yj)
        np.add.at(A, rows, np.abs(w)[:, None] * ayj)
        return ref, 1.01 * (2 * U32 + (n + 2) * 2.0 ** -40) * _norm(A)

    S1, eS = stencil_sum(st["w"])
    su1, e_su = stencil_sum(st["wu"])
    sv1, e_sv = stencil_sum(st["wv"])
    c = np.cross(su1, sv1)
    lc = _norm(c)
    e_c = e_su * _norm(sv1) + _norm(su1) * e_sv + e_su * e_sv + 4 * U32 * (_norm(su1) + e_su) * (_norm(sv1) + e_sv)
    e_N = np.where(e_c < lc, 2 * e_c / lc + 4 * U32, 2.0)
    ns = c / lc[:, None]
    fd = sm.frame_data()
    d = np.abs(np.asarray(fd["displacements"], float)) / s
    size = _norm(S1) + d
    e_p = 1.01 * (eS + d * e_N + 3 * U32 * d + U32 * size) + 2.0 ** -40 * size
    K = np.asarray(fd["normal_coefficients"], float)

    def tangent(k):
        a, b, g = K[:, 3 * k] * s, K[:, 3 * k + 1] * s, K[:, 3 * k + 2]
        f = a[:, None] * su1 + b[:, None] * sv1 + g[:, None] * ns
        err = (np.abs(a) * e_su + np.abs(b) * e_sv + np.abs(g) * e_N
               + 4 * U32 * (np.abs(a) * (_norm(su1) + e_su) + np.abs(b) * (_norm(sv1) + e_sv) + np.abs(g)))
        return f, 1.01 * err

    fu, e_fu = tangent(0)
    fv, e_fv = tangent(1)
    nn = _norm(np.cross(fu, fv))
    e_n = e_fu * _norm(fv) + _norm(fu) * e_fv + e_fu * e_fv + 4 * U32 * (_norm(fu) + e_fu) * (_norm(fv) + e_fv)
    angle = np.degrees(np.arcsin(np.minimum(1.0, e_n / nn)) + 4 * U32 + 2.0 ** -40)
    return e_p * s, (eS + 2.0 ** -40 * _norm(S1)) * s, angle


def _edit(C):
    """A moderate smooth edit: stretch, bend and twist of the control points (not affine,
    so the tangents turn differently everywhere)."""
    C = np.array(C, float)
    c = 0.5 * (C.min(axis=0) + C.max(axis=0))
    r = 0.5 * np.ptp(C, axis=0).max()
    x, y, z = ((C - c) / r).T
    t = 0.4 * z
    out = np.stack([x * np.cos(t) - y * np.sin(t) + 0.2 * z * z, x * np.sin(t) + y * np.cos(t), 1.15 * z], axis=1)
    return c + r * out


EDITS = {"identity": lambda sm: np.array(sm.control_points), "moderate": lambda sm: _edit(sm.control_points)}


def _frames(sm, C, precision):
    gpu = sm.deform(C, backend="vulkan", device=SEL, gpu_precision=precision)
    cpu = sm.deform(C, backend="cpu")
    return gpu, cpu


@pytest.mark.parametrize("edit", sorted(EDITS))
@pytest.mark.parametrize("name,scheme", CASES)
def test_frame_within_derived_bounds(name, scheme, edit, precision):
    mesh, sm = decomposition(name, scheme)
    C = EDITS[edit](sm)
    gpu, cpu = _frames(sm, C, precision)
    assert gpu.backend == "vulkan" and cpu.backend != "vulkan"
    frame = sm._vulkan_frame(SEL, precision)
    assert frame.precision == precision
    e_p, e_S, e_ang = subdiv_bounds(sm, frame, C)
    dp = _norm(gpu.vertices - cpu.vertices)
    dS = _norm(gpu.base_vertices - cpu.base_vertices)
    ang = angles_deg(gpu.normals, cpu.normals)
    diag = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    worst = int(np.argmax(dp / e_p))
    assert np.all(dp <= e_p), f"vertex {worst}: {dp[worst]:.3g} > bound {e_p[worst]:.3g}"
    assert np.all(dS <= e_S), f"limit point {int(np.argmax(dS / e_S))} beyond its bound"
    assert np.all(ang <= e_ang), f"normal {int(np.argmax(ang / e_ang))}: beyond its bound"
    # The bounds are a few float32 roundings of the sizes: they mean something.
    assert e_p.max() < 1e-5 * diag and e_ang.max() < 0.01
    print(f"\n{name}/{scheme}/{edit}/{precision}: |dp| max {dp.max() / diag:.2g} of the diagonal "
          f"(bound {e_p.max() / diag:.2g}), normals {ang.max():.2g} deg (bound {e_ang.max():.2g})")
    if edit == "identity":
        # The identity frame rebuilds the mesh: its foot points are exact to 1e-9 of
        # the diagonal (test_subdivision.FOOT), the device adds its bound.
        assert np.all(_norm(gpu.vertices - mesh.vertices) <= e_p + 1e-9 * diag)


@pytest.mark.parametrize("size", [1e-9, 1e9])
def test_any_mesh_size(size, precision):
    # Device lengths are in a power-of-two unit near the control points' size: without
    # it float-float (float32's exponent range) would underflow on a 1e-9 mesh's
    # squared tangents and overflow on a 1e9 one's crosses; the bound is relative.
    sm = vpffd.SubdivisionMultires(vpffd.shapes.bumpy_sphere(3, radius=size), control_vertices=80)
    C = _edit(sm.control_points)
    gpu, cpu = _frames(sm, C, precision)
    e_p, _, e_ang = subdiv_bounds(sm, sm._vulkan_frame(SEL, precision), C)
    assert np.all(_norm(gpu.vertices - cpu.vertices) <= e_p)
    assert np.all(angles_deg(gpu.normals, cpu.normals) <= e_ang)
    assert e_p.max() < 1e-6 * size

@pytest.mark.parametrize("name,scheme", CASES[:2])
def test_frames_repeat_bit_for_bit(name, scheme, precision):
    _, sm = decomposition(name, scheme)
    C = _edit(sm.control_points)
    a = sm.deform(C, backend="vulkan", device=SEL, gpu_precision=precision)
    sm.deform(sm.control_points, backend="vulkan", device=SEL, gpu_precision=precision)  # another frame between
    b = sm.deform(C, backend="vulkan", device=SEL, gpu_precision=precision)
    for x, y in ((a.vertices, b.vertices), (a.normals, b.normals), (a.base_vertices, b.base_vertices)):
        assert np.array_equal(x, y)


def test_bad_control_points_refused_like_the_cpu(precision):
    _, sm = decomposition("bumpy_sphere", "loop")
    C = np.array(sm.control_points)
    for bad in (C[:-1], C[:, :2], np.vstack([C, C[:1]])):
        with pytest.raises(vpffd.InvalidInputError) as cpu_err:
            sm.deform(bad, backend="cpu")
        with pytest.raises(vpffd.InvalidInputError) as gpu_err:
            sm.deform(bad, backend="vulkan", device=SEL, gpu_precision=precision)
        assert str(gpu_err.value) == str(cpu_err.value)
    for value in (np.nan, np.inf):
        X = C.copy()
        X[7, 1] = value
        with pytest.raises(vpffd.InvalidInputError) as cpu_err:
            sm.deform(X, backend="cpu")
        with pytest.raises(vpffd.InvalidInputError) as gpu_err:
            sm.deform(X, backend="vulkan", device=SEL, gpu_precision=precision)
        assert str(gpu_err.value) == str(cpu_err.value)
    # The compiled frames themselves refuse too (the same message as the CPU core's).
    frame = sm._vulkan_frame(SEL, precision)
    X = C.copy()
    X[7, 1] = np.nan
    with pytest.raises(vpffd.InvalidInputError) as gpu_err:
        frame.deform(X)
    with pytest.raises(vpffd.InvalidInputError) as cpu_err:
        sm._m.deform(X, 1)
    assert str(gpu_err.value) == str(cpu_err.value)
    with pytest.raises(vpffd.InvalidInputError, match="expected .* control points"):
        frame.deform(C[:-1])
    with pytest.raises(vpffd.InvalidInputError, match="beyond float32's range"):
        frame.deform(C * 1e40)


def test_bad_frame_data_refused():
    _, sm = decomposition("bumpy_sphere", "loop")
    indptr, indices, w, wu, wv = sm._m.stencils
    d, K, C = sm._m.displacements, sm._m.normal_coefficients, sm.control_points
    core = vpffd._core
    bad = np.array(indices)
    bad[3] = len(C)
    with pytest.raises(vpffd.InvalidInputError, match="out of range"):
        core.VulkanSubdivFrame(indptr, bad, w, wu, wv, d, K, C, SEL)
    with pytest.raises(vpffd.InvalidInputError, match="entries"):
        core.VulkanSubdivFrame(indptr, indices, w[:-1], wu, wv, d, K, C, SEL)
    nanw = np.array(w)
    nanw[0] = np.nan
    with pytest.raises(vpffd.InvalidInputError, match="not finite"):
        core.VulkanSubdivFrame(indptr, indices, nanw, wu, wv, d, K, C, SEL)
    with pytest.raises(vpffd.InvalidInputError, match="displacements"):
        core.VulkanSubdivFrame(indptr, indices, w, wu, wv, d[:-1], K, C, SEL)


def test_backend_choice(monkeypatch):
    _, sm = decomposition("bumpy_sphere", "loop")
    monkeypatch.delenv("VPFFD_VULKAN_DEVICE", raising=False)
    assert sm.deform(sm.control_points).backend != "vulkan"  # auto: the CPU unless a device is named
    assert sm.deform(sm.control_points, device=SEL).backend == "vulkan"
    monkeypatch.setenv("VPFFD_VULKAN_DEVICE", SEL)
    assert sm.deform(sm.control_points).backend == "vulkan"
    with pytest.raises(vpffd.InvalidInputError, match="unknown backend"):
        sm.deform(sm.control_points, backend="cuda")
    with pytest.raises(vpffd.InvalidInputError, match="only the 'vulkan' backend takes a device"):
        sm.deform(sm.control_points, backend="cpu", device=SEL)
    with pytest.raises(vpffd.InvalidInputError, match="gpu_precision"):
        sm.deform(sm.control_points, backend="vulkan", device=SEL, gpu_precision="half")


VALIDATION_LAYER = Path("/usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json")


@pytest.mark.skipif(not VALIDATION_LAYER.exists(), reason="Khronos validation layer not installed")
def test_validation_layer_reports_nothing():
    # Lavapipe forgives missing barriers that a real GPU would not: set-up and repeated
    # frames (the recorded command buffer resubmitted) of both precisions under the
    # validation layer with synchronization validation, which must report nothing.
    code = """
import numpy as np, vpffd
sm = vpffd.SubdivisionMultires(vpffd.shapes.bumpy_sphere(3), scheme="catmark", control_vertices=80)
for prec in ("float64", "float-float"):
    for k in range(3):
        sm.deform(sm.control_points * (1 + 0.1 * k), backend="vulkan", device=%r, gpu_precision=prec)
print("done")
""" % SEL
    env = dict(os.environ, VK_INSTANCE_LAYERS="VK_LAYER_KHRONOS_validation",
               VK_LAYER_ENABLES="VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT",
               VK_LOADER_DEBUG="layer", PYTHONWARNINGS="ignore")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    log = out.stdout + out.stderr
    assert 'Insert instance layer "VK_LAYER_KHRONOS_validation"' in log  # the layer really ran
    problems = [ln for ln in log.splitlines() if "Validation" in ln or "VUID-" in ln or "SYNC-" in ln]
    assert "done" in out.stdout and not problems, problems[:5]
