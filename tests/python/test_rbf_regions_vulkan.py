"""The RBF regions frame on the Vulkan device (shaders/rbf_regions.comp,
_core.VulkanRbfFrame, ``RBFDeformer.deform(transforms=..., backend="vulkan")``)
against the CPU frame (multires/rbf_regions.h), within per-vertex bounds derived below
from the device's float32 arithmetic; runs on lavapipe (a CPU Vulkan driver), in both
precisions (float64 and float-float affine sums).

The derivation (rbf_bounds), in device units y = (x - o) / s (o the rest fine and base
vertices' box centre, s a power of two, so the scaling is exact), u = 2^-24:

- free vertices: S' = S + sum_k D_k alpha_k (and S'_u, S'_v, the base vertex likewise)
  is formed in reals from real rest points, basis and maps: 8 K + 1 products and sums,
  each within 2^-44 (float-float; float64 2^-53) of the size A = |S| + sum_k |D_k||alpha_k|
  (componentwise, then the norm), plus the host's double conversions to device units and
  the CPU's own double sums, all below 2^-40 A each: at most (8 K + 4) 2^-40 A. It is
  then rounded once to float32: u |S'|. So e_S = u |S'| + (8 K + 4) 2^-40 A, and the
  rebuild (float32 cross, normalisation, p' = S' + d N_S', the approximate normal) adds
  what test_subdivision_vulkan.subdiv_bounds derives, with these e_S, e_su, e_sv;
- handle vertices: p' = T p in reals (4 terms) rounded to float32: u |p'| + 8 2^-40
  (|A||p| + |t|); the normal c = cof(A) n from the float32 rest normal (|dn| <= u) in
  reals, rounded to float32: e_c = ||cof||_2 u + u |c|, angle <= 2 e_c / |c| + 4u;
- fixed vertices: the rest data rounded to float32: u |p| and 4u for the normal.
Everything is multiplied by 1.01 for the second-order terms left out. The bound holds
on any driver that rounds float32 addition and multiplication correctly.
"""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import vpffd
from vpffd.normals import angles_deg
from test_vulkan import DEVICE, SEL
from test_vulkan import precision  # noqa: F401 (the fixture: both precisions, float64 where the device has it)
from test_rbf_regions import _affine, _rot

pytestmark = pytest.mark.skipif(DEVICE is None, reason="no Vulkan backend in this build or no suitable device")

U32 = 2.0 ** -24


def _norm(x):
    return np.linalg.norm(x, axis=-1)


def rbf_bounds(rd, frame, T):
    """Per vertex ((V,) world units, (V,) world units, (V,) degrees): bounds on the
    distance between the device's and the CPU's vertices p', base vertices, and the
    angle between their normals, for the K maps T (K, 4, 4); ``frame`` gives the
    device units (origin, scale). The derivation is the module's docstring."""
    mr, core = rd.multires, rd._regions
    K = core.n_regions
    T = np.asarray(T, float).reshape(K, 4, 4)
    o, s = np.asarray(frame.origin, float), float(frame.scale)
    lab = np.asarray(core.labels)
    V = len(lab)
    e_p, e_B, ang = np.zeros(V), np.zeros(V), np.zeros(V)

    # Fixed vertices: the rest data rounded once.
    fx = lab < 0
    e_p[fx] = 1.01 * U32 * _norm((mr.mesh.vertices[fx] - o) / s) + 2.0 ** -40
    e_B[fx] = 1.01 * U32 * _norm((mr.base.vertices[fx] - o) / s) + 2.0 ** -40
    ang[fx] = np.degrees(4 * U32)

    # Handle vertices: T_k in device units, rounded once; normals by the cofactor.
    for k in range(K):
        sel = lab == k + 1
        A = T[k, :3, :3]
        t = (A @ o + T[k, :3, 3] - o) / s
        nA = np.linalg.norm(A, 2)
        for P, e in ((mr.mesh.vertices, e_p), (mr.base.vertices, e_B)):
            p = (P[sel] - o) / s
            q = p @ A.T + t
            e[sel] = 1.01 * (U32 * _norm(q) + 8 * 2.0 ** -40 * (nA * _norm(p) + np.linalg.norm(t)))
        cof = np.linalg.det(A) * np.linalg.inv(A).T
        c = mr.rest_normals[sel] @ cof.T
        e_c = np.linalg.norm(cof, 2) * U32 + U32 * _norm(c)
        ang[sel] = np.degrees(1.01 * (2 * e_c / _norm(c) + 4 * U32))

    # Free vertices: the affine sums, then the rebuild.
    fr = np.flatnonzero(lab == 0)
    basis = np.asarray(core.basis).reshape(len(fr), 4, K, 4)  # [vertex, t (S, S_u, S_v, base), k, component]
    # As the frame: alpha in device units ((x - o w) / s, w), D_1 and D_k - D_1 likewise.
    a_dev = basis.copy()
    a_dev[..., :3] = (basis[..., :3] - o * basis[..., 3:]) / s
    D = T[:, :3, :].copy()
    D[:, :, :3] -= np.eye(3)
    D[1:] -= D[0]
    D_dev = D.copy()
    D_dev[:, :, 3] = (np.einsum("kac,c->ka", D[:, :, :3], o) + D[:, :, 3]) / s
    rest = [(mr._m.foot_points[fr] - o) / s, mr._m.tangents_u[fr] / s, mr._m.tangents_v[fr] / s,
            (mr.base.vertices[fr] - o) / s]
    vals, errs = [], []
    for t_ in range(4):
        val = rest[t_] + np.einsum("kac,nkc->na", D_dev, a_dev[:, t_])
        A_ = np.abs(rest[t_]) + np.einsum("kac,nkc->na", np.abs(D_dev), np.abs(a_dev[:, t_]))
        vals.append(val)
        errs.append(1.01 * (U32 * _norm(val) + (8 * K + 4) * 2.0 ** -40 * _norm(A_)))
    (S1, su1, sv1, B1), (eS, e_su, e_sv, eB) = vals, errs
    c = np.cross(su1, sv1)
    lc = _norm(c)
    e_c = e_su * _norm(sv1) + _norm(su1) * e_sv + e_su * e_sv + 4 * U32 * (_norm(su1) + e_su) * (_norm(sv1) + e_sv)
    e_N = np.where(e_c < lc, 2 * e_c / lc + 4 * U32, 2.0)
    ns = c / lc[:, None]
    d = np.abs(np.asarray(mr._m.displacements, float)[fr]) / s
    size = _norm(S1) + d
    e_p[fr] = 1.01 * (eS + d * e_N + 3 * U32 * d + U32 * size) + 2.0 ** -40 * size
    e_B[fr] = eB + 2.0 ** -40 * _norm(B1)
    Kc = np.asarray(mr._m.normal_coefficients, float)[fr]

    def tangent(j):
        a, b, g = Kc[:, 3 * j] * s, Kc[:, 3 * j + 1] * s, Kc[:, 3 * j + 2]
        f = a[:, None] * su1 + b[:, None] * sv1 + g[:, None] * ns
        err = (np.abs(a) * e_su + np.abs(b) * e_sv + np.abs(g) * e_N
               + 4 * U32 * (np.abs(a) * (_norm(su1) + e_su) + np.abs(b) * (_norm(sv1) + e_sv) + np.abs(g)))
        return f, 1.01 * err

    fu, e_fu = tangent(0)
    fv, e_fv = tangent(1)
    nn = _norm(np.cross(fu, fv))
    e_n = e_fu * _norm(fv) + _norm(fu) * e_fv + e_fu * e_fv + 4 * U32 * (_norm(fu) + e_fu) * (_norm(fv) + e_fv)
    ang[fr] = np.degrees(np.arcsin(np.minimum(1.0, e_n / nn)) + 4 * U32 + 2.0 ** -40)
    return e_p * s, e_B * s, ang


@pytest.fixture(scope="module")
def mesh():
    return vpffd.shapes.bumpy_sphere(4)  # 2,562 vertices


@pytest.fixture(scope="module")
def mr(mesh):
    return vpffd.Multires(mesh, smoothing=10)


@pytest.fixture(scope="module")
def rd(mr, mesh):
    """As test_rbf_regions.painted: deformable z > -0.2, the cap z > 0.7 and a patch on +x."""
    V = mesh.vertices
    x, z = V[:, 0], V[:, 2]
    h1 = np.flatnonzero(z > 0.7)
    h2 = np.flatnonzero((x > 0.6) & (z > 0) & (z < 0.5))
    return vpffd.RBFDeformer(mr, deformable=z > -0.2, handle_regions=[h1, h2])


EDITS = {
    "identity": [np.eye(4), np.eye(4)],
    "translate": [_affine(np.eye(3), [0, 0, 0.3]), _affine(np.eye(3), [0.2, 0, 0])],
    "rotate_scale": [_affine(1.2 * _rot(0.5), [0.1, -0.2, 0.25]), _affine(_rot(-0.3, (0, 1, 0)), [0.15, 0.05, 0])],
    "shear": [_affine(np.array([[1, 0.3, 0], [0, 1, 0], [0.1, 0, 0.8]]), [0, 0, 0.2]), np.eye(4)],
}


@pytest.mark.parametrize("edit", sorted(EDITS))
def test_frame_within_derived_bounds(rd, mr, mesh, edit, precision):
    T = EDITS[edit]
    gpu = rd.deform(transforms=T, backend="vulkan", device=SEL, gpu_precision=precision)
    cpu = rd.deform(transforms=T, backend="cpu")
    assert gpu.backend == "vulkan" and cpu.backend != "vulkan"
    frame = rd._vulkan_frame(SEL, precision)
    assert frame.precision == precision and frame.n_regions == 2 and frame.n_free == rd._regions.n_free
    e_p, e_B, e_ang = rbf_bounds(rd, frame, T)
    dp = _norm(gpu.vertices - cpu.vertices)
    dB = _norm(gpu.base_vertices - cpu.base_vertices)
    ang = angles_deg(gpu.normals, cpu.normals)
    diag = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    worst = int(np.argmax(dp / e_p))
    assert np.all(dp <= e_p), f"vertex {worst} (label {rd.labels[worst]}): {dp[worst]:.3g} > bound {e_p[worst]:.3g}"
    assert np.all(dB <= e_B), f"base vertex {int(np.argmax(dB / e_B))} beyond its bound"
    assert np.all(ang <= e_ang), f"normal {int(np.argmax(ang / e_ang))}: beyond its bound"
    # The bounds are a few float32 roundings of the sizes: they mean something.
    assert e_p.max() < 1e-5 * diag and e_ang.max() < 0.01
    print(f"\n{edit}/{precision}: |dp| max {dp.max() / diag:.2g} of the diagonal (bound {e_p.max() / diag:.2g}), "
          f"base {dB.max() / diag:.2g} (bound {e_B.max() / diag:.2g}), normals {ang.max():.2g} deg "
          f"(bound {e_ang.max():.2g})")


@pytest.mark.parametrize("size", [1e-9, 1e9])
def test_any_mesh_size(size, precision):
    # Device lengths are in a power-of-two unit near the mesh's size: without it
    # float-float (float32's exponent range) would underflow or overflow.
    mesh = vpffd.shapes.bumpy_sphere(3, radius=size)
    mr = vpffd.Multires(mesh, smoothing=10)
    z = mesh.vertices[:, 2] / size
    rd = vpffd.RBFDeformer(mr, deformable=z > -0.2, handle_regions=[np.flatnonzero(z > 0.7)])
    T = [_affine(_rot(0.4), [0, 0, 0.3 * size])]
    gpu = rd.deform(transforms=T, backend="vulkan", device=SEL, gpu_precision=precision)
    cpu = rd.deform(transforms=T, backend="cpu")
    e_p, _, e_ang = rbf_bounds(rd, rd._vulkan_frame(SEL, precision), T)
    assert np.all(_norm(gpu.vertices - cpu.vertices) <= e_p)
    assert np.all(angles_deg(gpu.normals, cpu.normals) <= e_ang)
    assert e_p.max() < 1e-6 * size


def test_frames_repeat_bit_for_bit(rd, precision):
    T = EDITS["rotate_scale"]
    a = rd.deform(transforms=T, backend="vulkan", device=SEL, gpu_precision=precision)
    rd.deform(transforms=EDITS["translate"], backend="vulkan", device=SEL, gpu_precision=precision)  # another between
    b = rd.deform(transforms=T, backend="vulkan", device=SEL, gpu_precision=precision)
    for x, y in ((a.vertices, b.vertices), (a.normals, b.normals), (a.base_vertices, b.base_vertices)):
        assert np.array_equal(x, y)


def test_bad_transforms_refused_like_the_cpu(rd, precision):
    frame = rd._vulkan_frame(SEL, precision)
    sing = np.eye(4)
    sing[2, 2] = 0.0
    nan = np.eye(4)
    nan[0, 3] = np.nan
    proj = np.eye(4)
    proj[3, 0] = 0.1
    for bad in ([np.eye(4)], [np.eye(4), sing], [nan, np.eye(4)], [np.eye(4), proj]):
        with pytest.raises(vpffd.InvalidInputError) as cpu_err:
            rd.deform(transforms=bad, backend="cpu")
        with pytest.raises(vpffd.InvalidInputError) as gpu_err:
            rd.deform(transforms=bad, backend="vulkan", device=SEL, gpu_precision=precision)
        assert str(gpu_err.value) == str(cpu_err.value)
        # The compiled frame itself: the CPU core's message.
        if len(bad) == 2:
            with pytest.raises(vpffd.InvalidInputError) as core_err:
                rd._regions.deform(bad, 1)
            with pytest.raises(vpffd.InvalidInputError) as dev_err:
                frame.deform(bad)
            assert str(dev_err.value) == str(core_err.value)
    with pytest.raises(vpffd.InvalidInputError, match="beyond float32's range"):
        frame.deform([_affine(np.eye(3), [1e40, 0, 0]), np.eye(4)])


def test_backend_choice(rd, mr, monkeypatch):
    monkeypatch.delenv("VPFFD_VULKAN_DEVICE", raising=False)
    T = EDITS["translate"]
    assert rd.deform(transforms=T).backend != "vulkan"  # auto: the CPU unless a device is named
    assert rd.deform(transforms=T, device=SEL).backend == "vulkan"
    monkeypatch.setenv("VPFFD_VULKAN_DEVICE", SEL)
    assert rd.deform(transforms=T).backend == "vulkan"
    with pytest.raises(vpffd.InvalidInputError, match="only the 'vulkan' backend takes a device"):
        rd.deform(transforms=T, backend="cpu", device=SEL)
    with pytest.raises(vpffd.InvalidInputError, match="gpu_precision"):
        rd.deform(transforms=T, backend="vulkan", device=SEL, gpu_precision="half")
    # The general mode has no device frame: refused when asked for, the CPU under "auto".
    general = vpffd.RBFDeformer(mr, rd.handles)
    assert general.deform(rd.handles).backend != "vulkan"
    with pytest.raises(vpffd.InvalidInputError, match="regions mode only"):
        general.deform(rd.handles, backend="vulkan", device=SEL)


VALIDATION_LAYER = Path("/usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json")


@pytest.mark.skipif(not VALIDATION_LAYER.exists(), reason="Khronos validation layer not installed")
def test_validation_layer_reports_nothing():
    # Set-up and repeated frames (the recorded command buffer resubmitted) of both
    # precisions under the validation layer with synchronization validation.
    code = """
import numpy as np, vpffd
mesh = vpffd.shapes.bumpy_sphere(3)
z = mesh.vertices[:, 2]
rd = vpffd.RBFDeformer(vpffd.Multires(mesh, smoothing=10), deformable=z > -0.2,
                       handle_regions=[np.flatnonzero(z > 0.7)])
for prec in ("float64", "float-float"):
    for k in range(3):
        T = np.eye(4); T[2, 3] = 0.1 * k
        rd.deform(transforms=T, backend="vulkan", device=%r, gpu_precision=prec)
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
