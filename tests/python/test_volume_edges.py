"""Volumes at the ends of the double range: every backend accepts and refuses the same
scales (a mesh and its lattice scaled together from 1e-300 to 1e300), with messages
that say what happened (the rest volume underflows, or overflows), and a target that
would flatten or invert the surface is refused unless asked for."""
import numpy as np
import pytest

import vpffd
from vpffd import edits, shapes

from gpu_bounds import check_frame
from test_frame_paths import _volume_error
from test_threads import backend_kwargs
from test_vulkan import DEVICE, SEL

SCALES = [1e-300, 1e-150, 1e-100, 1e-30, 1.0, 1e30, 1e100, 1e120, 1e300]


def _outcome(scale, backend):
    """('ok', (deformer, result, mesh, lattice)) or ('refused', message) for one
    volume-kept frame."""
    m = shapes.icosphere(3)
    mesh = vpffd.Mesh(m.vertices * scale, m.faces)
    kw = dict(backend=backend, device=SEL) if backend == "vulkan" else dict(backend=backend)
    try:
        lat = vpffd.Lattice.around(mesh, shape=(5, 5, 5), degree=3, padding=0.1)
        d = vpffd.Deformer(mesh, lat, **kw)
        r = d.deform(edits.squash(lat.control_points, 0.8))
    except (vpffd.InvalidInputError, vpffd.SolverError) as e:
        return "refused", str(e)
    return "ok", (d, r, mesh, lat)


def _backends():
    return ["serial"] + (["vulkan"] if DEVICE is not None else [])


@pytest.mark.parametrize("scale", SCALES)
def test_backends_agree_on_every_scale(scale):
    outcomes = {b: _outcome(scale, b) for b in _backends()}
    kinds = {b: o[0] for b, o in outcomes.items()}
    assert len(set(kinds.values())) == 1, outcomes
    kind, what = outcomes["serial"]
    if kind == "ok":
        # The CPU reaches its target to the rounding of its volume sums (the bound
        # derived for test_frame_paths); the device's frame agrees with the CPU's within
        # the bounds gpu_bounds derives from its float32 arithmetic. Both are relative to
        # the mesh's own size, so they hold at every scale.
        d, r, mesh, lat = what
        assert abs(r.volume - r.target_volume) <= _volume_error(d, r.vertices), (scale, r.volume_error)
        if "vulkan" in outcomes:
            check_frame(outcomes["vulkan"][1][1], r, mesh, lat)
    else:
        for b, (_, msg) in outcomes.items():
            assert ("underflow" in msg or "below the smallest normal double" in msg or "overflow" in msg
                    or "beyond" in msg or "double range" in msg), (b, msg)
    # In range, every scale works; the ends are refused, not "preserved" as 0 or inf.
    if 1e-100 <= scale <= 1e100:
        assert kind == "ok", outcomes
    if scale in (1e-300, 1e-150, 1e120, 1e300):
        assert kind == "refused", outcomes


def _sphere_deformer(backend):
    mesh = shapes.icosphere(3)
    lat = vpffd.Lattice.around(mesh, shape=(5, 5, 5), degree=3, padding=0.1)
    return mesh, lat, vpffd.Deformer(mesh, lat, **backend_kwargs(backend))


@pytest.mark.parametrize("backend", ["serial", "vulkan"])
def test_targets_that_invert_are_refused_unless_allowed(backend):
    mesh, lat, d = _sphere_deformer(backend)
    for t in (-1.0, 0.0):
        with pytest.raises(vpffd.InvalidInputError, match="other sign.*allow_inversion"):
            d.deform(target_volume=t)
    # Allowed, the inverted target is reached (to the CPU's derived rounding; the
    # device's bounds are derived for edits that do not turn a surface inside out, so
    # there only its sign is checked).
    r = d.deform(target_volume=-1.0, allow_inversion=True)
    assert r.volume < 0
    if backend == "serial":
        assert abs(r.volume + 1.0) <= _volume_error(d, r.vertices)
    # An inward-facing mesh keeps its own (negative) volume by default.
    inward = vpffd.Mesh(mesh.vertices, mesh.faces[:, ::-1])
    d = vpffd.Deformer(inward, lat, **backend_kwargs(backend))
    P = edits.squash(lat.control_points, 0.8)
    r = d.deform(P)
    cpu = vpffd.Deformer(inward, lat, backend="serial")
    c = cpu.deform(P)
    assert r.volume < 0 and c.target_volume == cpu.rest_volume < 0
    assert abs(c.volume - c.target_volume) <= _volume_error(cpu, c.vertices)
    if backend == "vulkan":
        check_frame(r, c, inward, lat)


def test_parts_targets_are_checked_per_part():
    s = shapes.icosphere(2)
    V = np.concatenate([0.4 * s.vertices - 0.5, 0.4 * s.vertices + 0.5])
    mesh = vpffd.Mesh(V, np.concatenate([s.faces, s.faces + s.n_vertices]))
    lat = vpffd.Lattice.around(mesh, shape=(5, 5, 5), degree=3, padding=0.1)
    d = vpffd.Deformer(mesh, lat, parts="components")
    with pytest.raises(vpffd.InvalidInputError, match="of part 1"):
        d.deform(target_volume=[0.2, -0.2])


@pytest.mark.parametrize("backend", ["serial", "vulkan"])
def test_targets_far_from_the_rest_volume_are_refused_alike(backend):
    mesh, lat, d = _sphere_deformer(backend)
    V0 = d.rest_volume
    for t in (1e300, V0 * 1e31, V0 * 1e-31, 1e-300):
        with pytest.raises(vpffd.InvalidInputError, match="factor of 1e30"):
            d.deform(target_volume=t)
    # Within the bound targets are reached: on the CPU to rounding even 1e6 times off;
    # the device's float32 positions keep moderate edits within gpu_bounds' 6e-8 relative.
    cpu = d if backend == "serial" else vpffd.Deformer(mesh, lat, backend="serial")
    for f in ((1e-6, 0.5, 8.0, 1e6) if backend == "serial" else (0.5, 2.0)):
        r = d.deform(target_volume=V0 * f)
        c = cpu.deform(target_volume=V0 * f)
        assert abs(c.volume - V0 * f) <= _volume_error(cpu, c.vertices)  # derived (test_frame_paths)
        if backend == "vulkan":
            check_frame(r, c, mesh, lat)  # within the device's derived bounds


@pytest.mark.skipif(not getattr(vpffd._core, "has_embree", False), reason="built without Embree")
@pytest.mark.parametrize("scale", [1e-200, 1e200, 1e300])
def test_pictures_at_any_scale(scale):
    """The picture of a mesh 1e200 (or 1e-200) across is the picture at scale 1: the
    camera and the rays are made without squaring world coordinates."""
    m = shapes.icosphere(3)
    ref = np.asarray(vpffd.rendering.render(m, size=(64, 48))).astype(int)
    img = np.asarray(vpffd.rendering.render(vpffd.Mesh(m.vertices * scale, m.faces), size=(64, 48))).astype(int)
    # Shading is the same; rays that graze the silhouette may hit or miss depending on
    # the last bits of the scaled coordinates, so a few edge pixels (under 1 % of a
    # 64 x 48 image, whose silhouette is about 3 %) may differ.
    assert np.mean(np.abs(img - ref) > 8) < 0.01


def test_a_zero_target_allowed_explicitly_is_not_bounded_below():
    """allow_inversion=True with target 0 flattens the surface: the 1e30 ratio bound
    (a guard against targets far from the rest volume) does not refuse it."""
    mesh = shapes.icosphere(3)
    lat = vpffd.Lattice.around(mesh, shape=(5, 5, 5), degree=3, padding=0.1)
    d = vpffd.Deformer(mesh, lat, backend="serial")
    r = d.deform(target_volume=0.0, axes="z", allow_inversion=True)
    assert abs(r.volume) <= 1e-12 * d.rest_volume
