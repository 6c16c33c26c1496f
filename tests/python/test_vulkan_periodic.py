"""Periodic lattices on the Vulkan backend (every seam, one or two periodic axes)
against the CPU: plain and corrected frames, weights, fixed points and point
constraints, rest meshes that cross the seam or lie whole extents away, moves across
the seam, and normals. Every comparison is within the bounds of gpu_bounds.py (their
periodic terms: the extended control points, the wrap's rounding, the shift seam's
translation), in both precisions."""
import numpy as np
import pytest

import vpffd
from vpffd import edits
from vpffd.normals import angles_deg, deformed_normals, vertex_normals
from gpu_bounds import Bounds, normal_angle_bound
from test_vulkan import DEVICE, SEL, assert_close
from test_vulkan import precision  # noqa: F401 (the fixture: both precisions, float64 where the device has it)

pytestmark = pytest.mark.skipif(DEVICE is None, reason="no Vulkan backend in this build or no suitable device")

BOX_MIN = np.array([-1.0, -0.5, -0.4])
BOX_MAX = np.array([2.0, 0.5, 0.4])
EXT = BOX_MAX - BOX_MIN

# name -> (periodic, seam, degree, the frames' base control points): closed and twist
# seams in the shapes they are for (a ring, a Moebius band), whose maps are no
# identity near the seam with the box's own control points.
LATTICES = {
    "shift": ("x", "shift", 3, lambda lat: lat.rest_points),
    "closed": ("x", "closed", 3, lambda lat: edits.ring(lat, radius=0.8, axis="x", around="z")),
    "twist": ("x", "twist", 3, lambda lat: edits.mobius(lat, radius=1.0)),
    "closed-shift-xy-quadratic": ("xy", {"x": "closed", "y": "shift"}, 2,
                                  lambda lat: edits.ring(lat, axis="x", around="y")),
}


def lattice(name):
    periodic, seam, degree, _ = LATTICES[name]
    return vpffd.Lattice(BOX_MIN, BOX_MAX, shape=(7, 5, 4), degree=degree, periodic=periodic, seam=seam)


def straddling_mesh(lat):
    """A sphere across the box's x = max face (a quarter of it past the seam) and, on
    a lattice periodic along y too, across y = max (wrapped along both axes)."""
    m = vpffd.shapes.icosphere(3, 0.3)
    return vpffd.Mesh(m.vertices + [1.85, 0.35 if "y" in lat.periodic else 0.0, 0.0], m.faces)


def edited(name, lat, seed=3, amount=0.01):
    """The base control points of lattice `name` (LATTICES), each moved at random by
    about `amount` of the box diagonal."""
    rng = np.random.default_rng(seed)
    return LATTICES[name][3](lat) + amount * np.linalg.norm(EXT) * rng.standard_normal(lat.rest_points.shape)


@pytest.fixture(scope="module", params=sorted(LATTICES))
def setup(request, precision):
    lat = lattice(request.param)
    mesh = straddling_mesh(lat)
    cpu = vpffd.Deformer(mesh, lat, backend="serial")
    gpu = vpffd.Deformer(mesh, lat, backend="vulkan", device=SEL, gpu_precision=precision)
    return request.param, lat, mesh, cpu, gpu


def inside_vertex(mesh):
    """A vertex well inside the box (a constraint source outside it along a shift
    seam is refused on every backend)."""
    d = np.abs(mesh.vertices - 0.5 * (BOX_MIN + BOX_MAX)) / (0.5 * EXT)
    return int(np.argmin(d.max(axis=1)))


def test_the_mesh_crosses_the_seam(setup):
    # Otherwise the tests below would not see the wrap.
    _, lat, mesh, _, _ = setup
    assert (mesh.vertices[:, 0] > BOX_MAX[0]).sum() > 20 and (mesh.vertices[:, 0] < BOX_MAX[0]).sum() > 20


def test_frames_match_cpu(setup):
    name, lat, mesh, cpu, gpu = setup
    P = edited(name, lat)
    v = inside_vertex(mesh)
    cons = [(v, cpu.ffd(P)[v] + [0.01, 0.0, 0.015])]  # not along y: axes="xz" below
    weights = np.linspace(1.0, 3.0, lat.n_control_points).reshape(lat.shape)
    fixed = np.zeros(lat.shape, bool)
    fixed[1, :, 0] = True
    subsets = [dict(axes=a) for a in ("x", "y", "z", "xy", "yz", "zx")]
    for kw in (dict(preserve_volume=False), dict(), dict(axes="zx", rounds=2), *subsets,
               dict(weights=weights, fixed=fixed), dict(constraints=cons),
               dict(constraints=cons, preserve_volume=False), dict(constraints=cons, axes="xz", weights=weights)):
        c, g = cpu.deform(P, **kw), gpu.deform(P, **kw)
        assert_close(g, c, lat, mesh, cpu)
        if kw.get("preserve_volume", True):
            # The volume is kept: the device's final volume is the target within its bound.
            assert abs(g.volume - c.rest_volume) <= Bounds(mesh, lat, c, P).corrected_volume + 1e-12 * c.rest_volume
        if "fixed" in kw:
            assert np.all(g.offsets[fixed] == 0)


def test_rest_mesh_whole_extents_away(setup, precision):
    # A rest mesh k extents along a periodic axis: "closed" maps it where the mesh
    # itself goes, "shift" there plus k extents, "twist" after two extents (one extent
    # mirrors it: compared with the CPU only).
    name, lat, mesh, cpu, gpu = setup
    P = edited(name, lat)
    for k in (-2, 1, 2):
        moved = vpffd.Mesh(mesh.vertices + [k * EXT[0], 0.0, 0.0], mesh.faces)
        cpu_m = vpffd.Deformer(moved, lat, backend="serial")
        gpu_m = vpffd.Deformer(moved, lat, backend="vulkan", device=SEL, gpu_precision=precision)
        for kw in (dict(preserve_volume=False), dict()):
            c, g = cpu_m.deform(P, **kw), gpu_m.deform(P, **kw)
            b = assert_close(g, c, lat, moved, cpu_m)
            seam = lat.seams["x"]
            if seam == "twist" and k % 2:
                continue
            g0 = gpu.deform(P, **kw)
            shift = [k * EXT[0], 0.0, 0.0] if seam == "shift" else [0.0, 0.0, 0.0]
            b0 = Bounds(mesh, lat, cpu.deform(P, **kw), P)
            assert np.abs(g.vertices - (g0.vertices + shift)).max() <= b.vertex + b0.vertex


def test_set_rest_vertices_across_the_seam(setup, precision):
    # Moves along the periodic axis in a row (through the seam and past it), each
    # equal to a fresh CPU Deformer on the moved mesh within the bound.
    name, lat, mesh, _, _ = setup
    gpu = vpffd.Deformer(mesh, lat, backend="vulkan", device=SEL, gpu_precision=precision)
    P = edited(name, lat, seed=5)
    for dx in (0.1, 0.25, 0.6, EXT[0] + 0.05, -1.3):
        X = mesh.vertices + [dx, 0.02, 0.0]
        moved = vpffd.Mesh(X, mesh.faces)
        gpu.set_rest_vertices(X)
        cpu = vpffd.Deformer(moved, lat, backend="serial")
        assert gpu.rest_volume == pytest.approx(cpu.rest_volume, rel=1e-14)
        for kw in (dict(preserve_volume=False), dict(axes="zx", rounds=2)):
            assert_close(gpu.deform(P, **kw), cpu.deform(P, **kw), lat, moved, cpu)


def test_set_rest_vertices_refuses_what_the_cpu_refuses(setup):
    # Outside the box along a non-periodic axis: the CPU's message, and nothing changes.
    name, lat, mesh, cpu, gpu = setup
    X = mesh.vertices + [0.0, 0.0, 0.5]
    with pytest.raises(vpffd.InvalidInputError) as cpu_err:
        vpffd.Deformer(vpffd.Mesh(X, mesh.faces), lat, backend="serial")
    with pytest.raises(vpffd.InvalidInputError) as gpu_err:
        gpu.set_rest_vertices(X)
    assert str(cpu_err.value).split("embed: ")[1] == str(gpu_err.value).split("embed: ")[1]
    np.testing.assert_array_equal(gpu.mesh.vertices, mesh.vertices)
    # Any distance along the periodic axis is inside ...
    gpu.set_rest_vertices(mesh.vertices + [40 * EXT[0], 0.0, 0.0])
    gpu.set_rest_vertices(mesh.vertices)
    # ... up to 2^24 extents on the device (its float32 positions keep nothing of the
    # place in the box beyond): a clear error, where the CPU wraps.
    X = mesh.vertices.copy()
    X[7, 0] += 2.0 ** 25 * EXT[0]
    vpffd.Deformer(vpffd.Mesh(X, mesh.faces), lat, backend="serial")
    with pytest.raises(vpffd.InvalidInputError, match=r"vertex 7 lies .* box extents away along periodic axis x"):
        gpu.set_rest_vertices(X)
    np.testing.assert_array_equal(gpu.mesh.vertices, mesh.vertices)


def test_outside_extrapolate(precision):
    # A mesh past the box along a non-periodic axis (extrapolated there) and across the
    # seam of the periodic one (wrapped).
    name = "twist"
    lat = lattice(name)
    m = vpffd.shapes.icosphere(3, 0.3)
    mesh = vpffd.Mesh(m.vertices + [1.85, 0.0, 0.25], m.faces)
    assert (mesh.vertices[:, 2] > BOX_MAX[2]).any()
    cpu = vpffd.Deformer(mesh, lat, backend="serial", outside="extrapolate")
    gpu = vpffd.Deformer(mesh, lat, backend="vulkan", device=SEL, gpu_precision=precision, outside="extrapolate")
    P = edited(name, lat)
    for kw in (dict(preserve_volume=False), dict()):
        assert_close(gpu.deform(P, **kw), cpu.deform(P, **kw), lat, mesh, cpu)


def test_normals_match_cpu(setup):
    name, lat, mesh, cpu, gpu = setup
    P = edited(name, lat, seed=11)
    for kw in (dict(preserve_volume=False), dict(), dict(axes="zx", rounds=2)):
        g = gpu.deform(P, normals=True, **kw)
        ang = angles_deg(g.normals, deformed_normals(cpu, g.control_points))
        bound = normal_angle_bound(lat, mesh.vertices, mesh.faces, g.control_points, cpu.jacobians(g.control_points),
                                   vertex_normals(mesh), g.offsets)
        assert np.all(ang <= bound), (ang.max(), bound[np.argmax(ang - bound)])
        # The 0.01 degree, proved by the bound for this edit.
        assert bound.max() < 0.01, bound.max()


def test_backend_choice():
    lat = lattice("closed")
    mesh = straddling_mesh(lat)
    assert vpffd.Deformer(mesh, lat, backend="vulkan", device=SEL).backend == "vulkan"
    # A named device makes "auto" use Vulkan, periodic or not.
    assert vpffd.Deformer(mesh, lat, backend="auto", device=SEL).backend == "vulkan"
    # A small mesh without a named device stays on the CPU (AUTO_GPU_MIN_VERTICES).
    assert vpffd.Deformer(mesh, lat, backend="auto").backend in ("openmp", "serial")
