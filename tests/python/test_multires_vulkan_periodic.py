"""The Vulkan multiresolution frame with periodic lattices (shift, closed and twist
seams) against the CPU's MultiresFFD, within gpu_bounds.multires_bounds (the periodic
terms included), in both precisions, on a body that straddles the seam: the box is
about 40 % of the body's length along the periodic axis, so most foot points are
wrapped into it, by one or two periods. Each seam test also shows that the bound is
far below what the seam changes, so a frame that dropped the translation or the mirror
would fail it."""
import numpy as np
import pytest

import vpffd
from vpffd import _core
from gpu_bounds import Bounds, multires_bounds
from test_multires_vulkan import _check
from test_vulkan import DEVICE, SEL
from test_vulkan import precision  # noqa: F401 (the fixture: both precisions, float64 where the device has it)

pytestmark = pytest.mark.skipif(DEVICE is None, reason="no Vulkan backend in this build or no suitable device")

SEAMS = ("shift", "closed", "twist")


@pytest.fixture(scope="module")
def long_body():
    """A bumpy body 5 units long in x, decomposed once (test_multires_periodic's)."""
    mesh = vpffd.shapes.bumpy_sphere(3, amplitude=0.08, frequency=8.0, stretch=(2.5, 1.0, 1.0))
    return mesh, vpffd.Multires(mesh, smoothing=6)


def _short_box(mesh, seam):
    lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    pad = 0.05 * (hi - lo)
    lo, hi = lo - pad, hi + pad
    lo[0], hi[0] = -1.0, 1.0
    return vpffd.Lattice(lo, hi, shape=(6, 5, 5), degree=3, periodic="x", seam=seam)


@pytest.fixture(scope="module", params=SEAMS)
def periodic_scene(request, long_body, precision):
    mesh, mr = long_body
    lat = _short_box(mesh, request.param)
    cpu = vpffd.MultiresDeformer(mr, lat, backend="serial")
    gpu = vpffd.MultiresDeformer(mr, lat, backend="vulkan", device=SEL, gpu_precision=precision)
    return request.param, mesh, mr, lat, cpu, gpu


def _edits(lat):
    rng = np.random.default_rng(11)
    return {
        "random": lat.control_points + 0.15 * rng.standard_normal(lat.control_points.shape),
        # About the periodic axis: across the seam the band comes back turned.
        "twist across the seam": vpffd.twist(lat.control_points, 50, axis="x"),
        "bend": vpffd.bend(lat.control_points, 40, axis="z"),
    }


def _diag(lat):
    return float(np.linalg.norm(lat.box_max - lat.box_min))


def test_periodic_frame_equals_cpu(periodic_scene):
    seam, mesh, mr, lat, cpu, gpu = periodic_scene
    assert gpu.backend == "vulkan"
    foot = mr.frame_data()["foot_points"]
    wrapped, mirrored = lat._spec.wrap_points(foot)
    assert np.mean(np.abs(foot[:, 0]) > 1.0) > 0.4  # the seams are exercised
    for name, P in _edits(lat).items():
        r = gpu.deform(P, preserve_volume=False)
        pos, ang = _check(mr, lat, cpu, P, r.vertices, r.normals)
        assert pos < 1e-4, (name, pos)
        Pf = np.ascontiguousarray(P.reshape(-1, 3))
        Xc, Nc = cpu._ffd.deform(Pf, 1)
        S1, J = cpu._ffd.foot_values_jacobians(Pf, 1)
        bp, _ = multires_bounds(lat, mr.frame_data(), Pf, S1, J)
        if seam == "shift":
            # Without the translation a wrapped point would be off by whole periods.
            moved = np.abs(wrapped[:, 0] - foot[:, 0]) > 1.0
            assert moved.sum() > 100
            assert np.all(np.abs((Xc - (foot - wrapped))[moved] - r.vertices[moved]).max(axis=1) > 100 * bp[moved])
        if seam == "twist":
            # Without the mirror of J (columns y, z negated) the deformed tangents, so
            # the rebuilt vertices, of the mirrored foot points would differ by much
            # more than the bound.
            m = np.asarray(mirrored, bool)
            assert m.sum() > 100
            fd = mr.frame_data()
            Jw = np.asarray(J).reshape(-1, 3, 3).copy()
            Jw[:, :, 1:] *= -1
            su1 = np.einsum("vij,vj->vi", Jw, fd["tangents_u"])
            sv1 = np.einsum("vij,vj->vi", Jw, fd["tangents_v"])
            ns = np.cross(su1, sv1)
            ns /= np.linalg.norm(ns, axis=1)[:, None]
            wrong = S1 + fd["displacements"][:, None] * ns
            gap = np.linalg.norm(wrong - Xc, axis=1)[m]
            assert np.median(gap / bp[m]) > 100, (name, np.median(gap / bp[m]))


def test_periodic_identity_reproduces_mesh(periodic_scene):
    seam, mesh, mr, lat, cpu, gpu = periodic_scene
    r = gpu.deform(preserve_volume=False)
    P = np.ascontiguousarray(lat.control_points.reshape(-1, 3))
    S1, J = cpu._ffd.foot_values_jacobians(P, 1)
    bp, _ = multires_bounds(lat, mr.frame_data(), P, S1, J)
    # The CPU's rest frame is the mesh to 1e-12 of the diagonal (test_multires_periodic)
    # for "shift"; "closed" and "twist" are not the identity outside the box.
    Xc, _ = cpu._ffd.deform(P, 1)
    if seam == "shift":
        assert np.abs(Xc - mesh.vertices).max() <= 1e-12 * _diag(lat)
    assert np.all(np.linalg.norm(r.vertices - Xc, axis=1) <= bp)


@pytest.mark.parametrize("volume", ["base", "fine"])
def test_periodic_volume_modes(periodic_scene, volume):
    """The correction on the device (the periodic Vulkan Deformer: offsets of the
    distinct control points) drives the reconstruction in the same submission: the
    tied copies get their distinct point's offset through the tie map."""
    seam, mesh, mr, lat, cpu, gpu = periodic_scene
    P = vpffd.edits.squash(lat.control_points, 0.7, axis="z")
    r = gpu.deform(P, volume=volume)
    assert r.volume_mode == volume and r.backend == "vulkan"
    assert r.control_points.shape == lat.control_points.shape
    offsets = r.control_points - P
    assert np.abs(offsets).max() > 1e-3 * _diag(lat)  # a real correction, on the tied slices too
    _check(mr, lat, cpu, r.control_points, r.vertices, r.normals, offsets=offsets)
    # The deformed base: the base Deformer's device FFD (its own bound is ~3e-5 of the
    # diagonal for a cubic lattice, gpu_bounds.Bounds).
    np.testing.assert_allclose(r.base_vertices, cpu._base.ffd(r.control_points), rtol=0, atol=1e-4 * _diag(lat))
    if volume == "base":
        # The base's corrected volume: the periodic Vulkan Deformer's derived bound.
        b = Bounds(mr.base, lat, cpu._base.deform(P), P.reshape(-1, 3))
        assert abs(r.base_volume - r.base_rest_volume) <= b.corrected_volume + 1e-12 * abs(r.base_rest_volume)


def test_periodic_one_submission_equals_standalone(periodic_scene):
    """Without a correction the tail of the Deformer's submission reads the very
    floats a standalone frame uploads: the Deformer expands the distinct points as the
    frame does (one rounding of each extended point)."""
    seam, mesh, mr, lat, cpu, gpu = periodic_scene
    P = vpffd.twist(lat.control_points, 50, axis="x")
    r = gpu.deform(P, preserve_volume=False)
    X, N = gpu._vk.deform(np.ascontiguousarray(P.reshape(-1, 3)))
    np.testing.assert_array_equal(r.vertices, X)
    np.testing.assert_array_equal(r.normals, N)


def test_periodic_needs_the_same_seams(long_body):
    """A Deformer of the same box and knots but other seams cannot drive the frame."""
    mesh, mr = long_body
    shift, closed = _short_box(mesh, "shift"), _short_box(mesh, "closed")
    vk = _core.VulkanMultires(mr._m, shift._spec, SEL, "auto")
    d = vpffd.Deformer(mr.base, closed, backend="vulkan", device=SEL)
    opts = _core.CorrectionOptions(preserve_volume=False)
    P = np.ascontiguousarray(closed.control_points.reshape(-1, 3))
    with pytest.raises(vpffd.InvalidInputError, match="another lattice"):
        vk.deform_after(d._vk, P, opts, None, None, None)
    with pytest.raises(vpffd.InvalidInputError, match="control points"):
        vk.deform(np.zeros((shift.n_control_points + 1, 3)))


@pytest.mark.parametrize("seam", SEAMS)
def test_periodic_frame_on_a_scan(shared_meshes, precision, seam):
    """A real scan (the horse: thin legs, noise, lifted vertices) under a periodic
    lattice whose box is 40 % of the body along the periodic axis: device and CPU
    within the derived bounds, the seams exercised."""
    mesh = vpffd.load_mesh(shared_meshes / "horse.ply")
    mr = vpffd.Multires(mesh)
    V = mesh.vertices
    lo, hi = V.min(axis=0), V.max(axis=0)
    ax = int(np.argmax(hi - lo))
    pad = 0.05 * (hi - lo)
    lo, hi = lo - pad, hi + pad
    c, half = 0.5 * (lo[ax] + hi[ax]), 0.2 * (hi[ax] - lo[ax])
    lo[ax], hi[ax] = c - half, c + half
    lat = vpffd.Lattice(lo, hi, shape=(6, 6, 6), degree=3, periodic="xyz"[ax], seam=seam)
    foot = mr.frame_data()["foot_points"]
    assert np.mean(np.abs(foot[:, ax] - c) > half) > 0.4  # most foot points are wrapped
    cpu = vpffd.MultiresDeformer(mr, lat, backend="serial")
    gpu = vpffd.MultiresDeformer(mr, lat, backend="vulkan", device=SEL, gpu_precision=precision)
    rng = np.random.default_rng(5)
    for P in (lat.control_points + 0.02 * _diag(lat) * rng.standard_normal(lat.control_points.shape),
              vpffd.twist(lat.control_points, 40, axis="xyz"[ax])):
        r = gpu.deform(P, preserve_volume=False)
        pos, _ = _check(mr, lat, cpu, P, r.vertices, r.normals)
        assert pos < 1e-4, pos
