"""Parts (several objects, each keeping its own volume) on the Vulkan backend.

The device sorts each part's vertices into one range (the sort key is part * N + cell),
so every tile belongs to one part; combine.comp sums one coefficient row per part and
solve.comp solves the K volume rows with the point constraints. Each part's volume is
then restored as the whole mesh's is without parts, and the bounds of gpu_bounds.py
apply part by part: a part's volume is a sum over its own vertices (its faces), each
step measures it on the device and takes its share of what it misses, so only the last
gather's rounding of the part's vertices is left unmeasured, sum over the part's
vertices of |g_v,a| E_v,a, which the whole-mesh bound Bounds.corrected_volume (the same
sum over all vertices, plus the sums' rounding over all faces) covers. The vertices, the
step records and the plain volumes are compared with the CPU frame with the same parts
by check_frame; the steps' share is the sum of the parts' shares, each of which differs
from the CPU's by at most its part's plain-volume error, whose sum is the whole mesh's;
check_frame's offset test takes the smallest part's share (gpu_bounds.Bounds).
"""
import numpy as np
import pytest

import vpffd
from vpffd import edits, shapes
from gpu_bounds import check_frame
from test_vulkan import DEVICE, SEL, gpu_deformer
from test_vulkan import precision  # noqa: F401 (the fixture: both precisions, float64 where the device has it)

pytestmark = pytest.mark.skipif(DEVICE is None, reason="no Vulkan backend in this build or no suitable device")


def spheres(count, subdivisions=2, gap=3.0):
    """`count` spheres `gap` apart along x, of radii 1, 0.85, 0.7... (parts that miss
    different volumes under one edit), as one mesh, and their labels (0, 10, 20...)."""
    s = shapes.icosphere(subdivisions)
    nv = s.n_vertices
    radius = [max(1.0 - 0.15 * i, 0.5) for i in range(count)]
    V = np.concatenate([radius[i] * s.vertices + [gap * i, 0, 0] for i in range(count)])
    F = np.concatenate([s.faces + i * nv for i in range(count)])
    return vpffd.Mesh(V, F), np.repeat(10 * np.arange(count), nv)


def _rest_sums_agree(g, c, mesh, labels, origin):
    """The rest part volumes: the same float64 face sums on the host (volume/
    part_coefficients.h part_volumes) that a compiler may contract differently in two
    translation units: (n + 6) 2^-53 of each part's sum of absolute terms."""
    for k, lab in enumerate(np.unique(labels)):
        F = mesh.faces[labels[mesh.faces[:, 0]] == lab]
        Y = mesh.vertices - origin
        terms = np.abs(np.einsum("ij,ij->i", Y[F[:, 0]], np.cross(Y[F[:, 1]], Y[F[:, 2]]))).sum() / 6
        assert abs(g[k] - c[k]) <= (len(F) + 6) * 2.0 ** -53 * terms


def _check_parts(rg, rc, bounds, targets):
    """A corrected frame's part volumes: each on its target within the device's bound,
    and against the CPU's through the targets (triangle inequality: the CPU's own miss,
    as it landed, plus a few ulps for the two subtractions)."""
    assert rg.part_volumes.shape == rc.part_volumes.shape
    assert np.array_equal(rg.part_target_volumes, targets)
    assert np.abs(rg.part_volumes - targets).max() <= bounds.corrected_volume
    cpu_miss = np.abs(rc.part_volumes - targets) + 4 * 2.0 ** -53 * np.abs(targets)
    assert np.all(np.abs(rg.part_volumes - rc.part_volumes) <= bounds.corrected_volume + cpu_miss)
    assert np.abs(rg.part_volumes_before - rc.part_volumes_before).max() <= bounds.plain_volume


@pytest.mark.parametrize("count", [2, 3])
def test_every_part_keeps_its_volume_like_the_cpu(precision, count):
    mesh, labels = spheres(count)
    lat = vpffd.Lattice.around(mesh, shape=(8, 5, 5))
    g = gpu_deformer(mesh, lat, precision, parts=labels)
    c = vpffd.Deformer(mesh, lat, parts=labels, backend="serial")
    assert g.backend == "vulkan" and g.n_parts == count
    rest = g.rest_part_volumes
    _rest_sums_agree(rest, c.rest_part_volumes, mesh, labels, lat.center)
    assert g.rest_volume == rest.sum()
    P = edits.squash(edits.twist(lat.control_points, np.pi, axis="z"), 0.7, axis="z")
    P[:3, ..., 1] *= 0.8  # the first part is squashed more
    rg, rc = g.deform(P), c.deform(P)
    b = check_frame(rg, rc, mesh, lat, cpu=c)
    _check_parts(rg, rc, b, rest)
    # The plain FFD changed every part far beyond the bound (the test is not vacuous).
    assert np.abs(rg.part_volumes_before - rest).min() > 100 * b.corrected_volume
    # Every sum in a fixed order: a rerun is bit-identical.
    again = g.deform(P)
    assert np.array_equal(again.vertices, rg.vertices) and np.array_equal(again.part_volumes, rg.part_volumes)


def test_axis_subsets_targets_and_fixed_points(precision):
    mesh, labels = spheres(3)
    lat = vpffd.Lattice.around(mesh, shape=(9, 5, 5))
    g = gpu_deformer(mesh, lat, precision, parts="components")
    c = vpffd.Deformer(mesh, lat, parts="components", backend="serial")
    P = edits.squash(lat.control_points, 0.6, axis="z")
    targets = g.rest_part_volumes * [1.0, 1.2, 0.8]
    fixed = np.zeros(lat.shape, bool)
    fixed[:, 0] = True  # a face of the lattice stays
    for kw in (dict(axes="zx", rounds=2, target_volume=targets), dict(axes="y", fixed=fixed)):
        rg, rc = g.deform(P, **kw), c.deform(P, **kw)
        b = check_frame(rg, rc, mesh, lat, cpu=c)
        _check_parts(rg, rc, b, kw.get("target_volume", g.rest_part_volumes))
    # Uncorrected frames report each part's volume too.
    rg, rc = g.deform(P, preserve_volume=False), c.deform(P, preserve_volume=False)
    b = check_frame(rg, rc, mesh, lat, cpu=c)
    assert np.abs(rg.part_volumes - rc.part_volumes).max() <= b.plain_volume
    assert np.array_equal(rg.part_volumes, rg.part_volumes_before) and rg.part_target_volumes is None


def test_point_constraints_together_with_parts(precision):
    mesh, labels = spheres(2)
    lat = vpffd.Lattice.around(mesh, shape=(8, 6, 6))
    g = gpu_deformer(mesh, lat, precision, parts=labels)
    c = vpffd.Deformer(mesh, lat, parts=labels, backend="serial")
    v0, v1 = 0, mesh.n_vertices // 2 + 5
    cons = [(v0, mesh.vertices[v0] + [0, 0.2, 0.1]), (v1, mesh.vertices[v1] + [-0.1, 0, 0.15])]
    P = edits.squash(lat.control_points, 0.7, axis="z")
    rg, rc = g.deform(P, constraints=cons), c.deform(P, constraints=cons)
    b = check_frame(rg, rc, mesh, lat, cpu=c)
    _check_parts(rg, rc, b, g.rest_part_volumes)
    # Constraint rows of O(1) basis values on O(1) coordinates, solved in reals: the
    # tolerance of the other Vulkan constraint tests (test_vulkan.py).
    assert rg.constraint_error <= 1e-9
    # Constraints alone: solved on the host, parts measured on the device.
    rg, rc = g.deform(P, preserve_volume=False, constraints=cons[:1]), c.deform(P, preserve_volume=False,
                                                                                  constraints=cons[:1])
    b = check_frame(rg, rc, mesh, lat, cpu=c)
    assert np.abs(rg.part_volumes - rc.part_volumes).max() <= b.plain_volume


def test_a_move_with_parts_equals_a_fresh_deformer(precision):
    mesh, labels = spheres(2)
    lat = vpffd.Lattice.around(mesh, shape=(8, 6, 6), padding=0.3)
    g = gpu_deformer(mesh, lat, precision, parts=labels)
    P = edits.twist(lat.control_points, 0.5 * np.pi, axis="z")
    g.deform(P)
    for step in (1, 2):
        X = mesh.vertices + np.array([0.08, -0.05, 0.03]) * step
        X[labels == 10] *= [1.0, 1.1, 0.9]  # the second part changes shape too
        g.set_rest_vertices(X)
        moved = vpffd.Mesh(X, mesh.faces)
        fresh = gpu_deformer(moved, lat, precision, parts=labels)
        c = vpffd.Deformer(moved, lat, parts=labels, backend="serial")
        # The same host code on the same data: the rest part volumes and the targets.
        assert np.array_equal(g.rest_part_volumes, fresh.rest_part_volumes)
        _rest_sums_agree(g.rest_part_volumes, c.rest_part_volumes, moved, labels, lat.center)
        rc = c.deform(P)
        for r in (g.deform(P), fresh.deform(P)):
            b = check_frame(r, rc, moved, lat, cpu=c)
            _check_parts(r, rc, b, g.rest_part_volumes)


def test_solver_errors_name_the_parts(precision):
    mesh, labels = spheres(2)
    lat = vpffd.Lattice.around(mesh, shape=(8, 5, 5))
    g = gpu_deformer(mesh, lat, precision, parts=labels)
    P = edits.twist(lat.control_points, np.pi, axis="z")
    B = g.basis_matrix()
    touches_1 = np.asarray(abs(B[labels == 10]).sum(axis=0)).ravel() > 0
    good = g.deform(P).vertices
    with pytest.raises(vpffd.SolverError, match="volume coefficients of part 1 are zero"):
        g.deform(P, fixed=touches_1)
    assert np.array_equal(g._vk.vertices(), good)  # the failed frame left nothing behind
    # Two coincident copies of one sphere: their volume rows are equal.
    s = shapes.icosphere(2)
    twin = vpffd.Mesh(np.concatenate([s.vertices, s.vertices]), np.concatenate([s.faces, s.faces + s.n_vertices]))
    lat2 = vpffd.Lattice.around(twin, shape=(5, 5, 5))
    d = gpu_deformer(twin, lat2, precision, parts="components")
    with pytest.raises(vpffd.SolverError, match="linearly dependent.*part 0, part 1"):
        d.deform(edits.twist(lat2.control_points, np.pi, axis="z"))
    assert d.deform(lat2.control_points, preserve_volume=False).part_volumes.shape == (2,)


def test_bad_parts_on_vulkan(precision):
    mesh, labels = spheres(2)
    lat = vpffd.Lattice.around(mesh, shape=(8, 5, 5))
    open_mesh = vpffd.Mesh(mesh.vertices, mesh.faces[:-1])
    with pytest.raises(vpffd.InvalidInputError, match=r"part 1 \(label 10\) is open \(3 boundary edges\)"):
        gpu_deformer(open_mesh, lat, precision, parts=labels)
    many, many_labels = spheres(65, subdivisions=0, gap=2.5)
    many_lat = vpffd.Lattice.around(many, shape=(6, 4, 4))
    with pytest.raises(vpffd.BackendUnavailableError, match="65 parts; the Vulkan backend keeps at most 64"):
        gpu_deformer(many, many_lat, precision, parts=many_labels)
    # "auto" with a device asked for falls back to the CPU, saying why.
    with pytest.warns(UserWarning, match="at most 64 parts"):
        d = vpffd.Deformer(many, many_lat, backend="auto", device=SEL, parts=many_labels)
    assert d.backend in ("openmp", "serial") and d.n_parts == 65


def test_parts_on_a_periodic_lattice(precision):
    # The fold of the periodic ties (combine.comp) applies to every part's row; the second
    # sphere straddles the seam (its rest positions are wrapped on the device).
    mesh, labels = spheres(2)
    V = mesh.vertices.copy()
    V[labels == 10, 0] += 1.4  # centre at x = 4.4 in a box that ends at 4.5
    mesh = vpffd.Mesh(V, mesh.faces)
    lat = vpffd.Lattice([-1.5, -1.5, -1.5], [4.5, 1.5, 1.5], shape=(8, 5, 5), degree=3, periodic="x")
    g = gpu_deformer(mesh, lat, precision, parts=labels)
    c = vpffd.Deformer(mesh, lat, parts=labels, backend="serial")
    P = edits.squash(lat.control_points, 0.7, axis="z")
    P[:3, ..., 1] *= 0.8
    rg, rc = g.deform(P), c.deform(P)
    b = check_frame(rg, rc, mesh, lat, cpu=c)
    _check_parts(rg, rc, b, g.rest_part_volumes)
