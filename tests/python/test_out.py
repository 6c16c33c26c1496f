"""``out=``: frames written into the caller's arrays on every backend and entry point.
The array given is the result's (same memory), bit for bit what a call without it
returns; bad arrays are refused with clear errors before anything is written."""
import numpy as np
import pytest

import vpffd
from vpffd import edits, shapes

from test_threads import BACKENDS, backend_kwargs

@pytest.fixture(scope="module")
def scene():
    mesh = shapes.icosphere(3)
    lat = vpffd.Lattice.around(mesh, shape=(6, 6, 6), degree=3, padding=0.05)
    return mesh, lat, edits.twist(edits.squash(lat.control_points, 0.8), 30)


def _fresh(n):
    return np.full((n, 3), np.nan)  # a frame that writes nothing would leave NaN


@pytest.mark.parametrize("backend", BACKENDS)
def test_deformer_frames_into_out(scene, backend):
    mesh, lat, P = scene
    d = vpffd.Deformer(mesh, lat, **backend_kwargs(backend))
    n = mesh.n_vertices
    out = _fresh(n)
    X = d.ffd(P, out=out)
    assert X is out and np.array_equal(out, d.ffd(P))
    for kw in (dict(), dict(preserve_volume=False), dict(axes="zx", rounds=2), dict(normals=True)):
        out, outn = _fresh(n), _fresh(n)
        extra = dict(out_normals=outn) if kw.get("normals") else {}
        r = d.deform(P, out=out, **kw, **extra)
        ref = d.deform(P, **kw)
        assert r.vertices is out and np.array_equal(out, ref.vertices), kw
        assert r.volume == ref.volume
        if kw.get("normals"):
            assert r.normals is outn and np.array_equal(outn, ref.normals)
    # The same array frame after frame: a loop that allocates no output.
    out = _fresh(n)
    for f in (0.9, 0.8, 0.7):
        r = d.deform(edits.squash(lat.control_points, f), out=out)
        assert r.vertices is out
        assert np.array_equal(out, d.deform(edits.squash(lat.control_points, f)).vertices)


def test_deform_points_into_out(scene):
    mesh, lat, P = scene
    X = mesh.vertices[::3].copy()
    out = _fresh(len(X))
    assert lat.deform_points(X, P, out=out) is out
    assert np.array_equal(out, lat.deform_points(X, P))


@pytest.mark.parametrize("backend", BACKENDS)
def test_multires_frames_into_out(scene, backend):
    mesh, lat, P = scene
    md = vpffd.MultiresDeformer(vpffd.Multires(mesh, smoothing=5), lat, **backend_kwargs(backend))
    n = mesh.n_vertices
    for kw in (dict(), dict(preserve_volume=False), dict(volume="fine"), dict(normals="exact")):
        out, outn = _fresh(n), _fresh(n)
        r = md.deform(P, out=out, out_normals=outn, **kw)
        ref = md.deform(P, **kw)
        assert r.vertices is out and r.normals is outn, kw
        assert np.array_equal(out, ref.vertices) and np.array_equal(outn, ref.normals), kw
    out = _fresh(n)
    r = md.deform(P, out=out)  # the normals in an array of the frame's own
    assert r.vertices is out and np.array_equal(r.normals, md.deform(P).normals)


def test_bad_out_arrays_are_refused_and_untouched(scene):
    mesh, lat, P = scene
    d = vpffd.Deformer(mesh, lat, backend="serial")
    n = mesh.n_vertices
    Pflat = np.ascontiguousarray(P.reshape(-1, 3))
    shared = np.zeros((n + len(Pflat), 3))
    shared[:len(Pflat)] = Pflat
    cases = [
        (list(np.zeros((n, 3))), TypeError, "numpy array"),
        (np.zeros((n, 3), np.float32), TypeError, "float64"),
        (np.zeros((n, 2)), vpffd.InvalidInputError, r"shape \(%d, 3\)" % n),
        (np.zeros((n + 1, 3)), vpffd.InvalidInputError, "shape"),
        (np.zeros((n, 3), order="F"), vpffd.InvalidInputError, "C-contiguous"),
        (np.zeros((2 * n, 3))[::2], vpffd.InvalidInputError, "C-contiguous"),
    ]
    ro = np.zeros((n, 3))
    ro.flags.writeable = False
    cases.append((ro, vpffd.InvalidInputError, "read-only"))
    for bad, err, match in cases:
        before = np.array(bad, copy=True)
        for call in (lambda: d.ffd(P, out=bad), lambda: d.deform(P, out=bad)):
            with pytest.raises(err, match=match):
                call()
        assert np.array_equal(np.asarray(bad), before)
    # Memory shared with the control points the frame reads.
    with pytest.raises(vpffd.InvalidInputError, match="shares memory with control_points"):
        d.deform(shared[:len(Pflat)], out=shared[len(Pflat) - 1:len(Pflat) - 1 + n])
    with pytest.raises(vpffd.InvalidInputError, match="normals=True"):
        d.deform(P, out_normals=np.zeros((n, 3)))
    X = mesh.vertices.copy()
    with pytest.raises(vpffd.InvalidInputError, match="shares memory with points"):
        lat.deform_points(X, P, out=X)


@pytest.mark.parametrize("backend", BACKENDS)
def test_frames_reuse_only_arrays_nobody_holds(scene, backend):
    """Without out=, a frame writes into the array of an earlier frame once nothing
    holds it (no page faults for a fresh output); held results and views never change."""
    mesh, lat, P = scene
    d = vpffd.Deformer(mesh, lat, **backend_kwargs(backend))
    P2 = edits.squash(lat.control_points, 0.6)
    held = d.deform(P)
    kept = held.vertices.copy()
    view = d.deform(P2).vertices[:7]
    kept_view = view.copy()
    for _ in range(3):
        d.deform(P2)
        d.ffd(P2)
    assert np.array_equal(held.vertices, kept) and np.array_equal(view, kept_view)
    # Dropped arrays are reused (CPython's reference counts are exact).
    a = d.deform(P2).vertices.ctypes.data
    assert d.deform(P).vertices.ctypes.data == a
    b = d.ffd(P2).ctypes.data
    assert d.ffd(P).ctypes.data == b
    assert np.array_equal(d.deform(P).vertices, kept)
    md = vpffd.MultiresDeformer(vpffd.Multires(mesh, smoothing=5), lat, **backend_kwargs(backend))
    first = md.deform(P)
    ref_x, ref_n = first.vertices.copy(), first.normals.copy()
    x = md.deform(P2).vertices.ctypes.data
    r = md.deform(P)
    assert r.vertices.ctypes.data == x
    assert np.array_equal(r.vertices, ref_x) and np.array_equal(r.normals, ref_n)
    assert np.array_equal(first.vertices, ref_x)  # held: untouched


def test_vulkan_normals_without_out_normals_after_reuse(scene):
    """A frame that reuses its vertex array and asks for normals without out_normals
    still returns them (the device's read back into a buffer of its own)."""
    mesh, lat, P = scene
    d = vpffd.Deformer(mesh, lat, **backend_kwargs("vulkan"))
    ref = d.deform(P, normals=True)
    ref_n = ref.normals.copy()
    del ref
    r = d.deform(P, normals=True)  # its vertices go into the dropped frame's array
    assert r.normals.shape == (mesh.n_vertices, 3) and np.array_equal(r.normals, ref_n)
