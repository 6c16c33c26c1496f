"""Vertices and normals put in the caller's vertex order on the device (place.comp)
against the device's order reordered on the host (VPFFD_VULKAN_READBACK=host): the
same bits, in both precisions, for plain and volume-preserving frames, with normals,
`out=`, parts, periodic lattices, after a move and through vertices()."""
import numpy as np
import pytest

import vpffd
from vpffd import edits, shapes

from test_vulkan import DEVICE, SEL
from test_vulkan import precision  # noqa: F401 (the fixture: both precisions, float64 where the device has it)
from test_vulkan_parts import spheres

pytestmark = pytest.mark.skipif(DEVICE is None, reason="no Vulkan backend in this build or no suitable device")


def bits(a):
    """The exact bits of a float64 array (-0.0 and 0.0 differ, NaNs compare)."""
    return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)


def same_bits(a, b):
    assert a.shape == b.shape
    ia, ib = bits(a), bits(b)
    if not np.array_equal(ia, ib):
        rows = np.nonzero((ia != ib).any(axis=1))[0]
        pytest.fail(f"{rows.size} rows differ, the first {rows[0]}: {a[rows[0]]} against {b[rows[0]]}")


def both(monkeypatch, mesh, lat, precision, **kw):
    """Deformers reading back in the caller's order made on the device and on the host."""
    out = []
    for where in ("device", "host"):
        monkeypatch.setenv("VPFFD_VULKAN_READBACK", where)
        out.append(vpffd.Deformer(mesh, lat, backend="vulkan", device=SEL, gpu_precision=precision, **kw))
    monkeypatch.delenv("VPFFD_VULKAN_READBACK")
    return out


def frames(lat):
    P = edits.squash(lat.control_points, 0.8)
    return [dict(control_points=P, preserve_volume=False),
            dict(control_points=P),
            dict(control_points=P, normals=True),
            dict(control_points=P, axes="y", normals=True, preserve_volume=False)]


def compare(dev, host, lat, nv):
    for kw in frames(lat):
        a, b = dev.deform(**kw), host.deform(**kw)
        same_bits(a.vertices, b.vertices)
        if kw.get("normals"):
            same_bits(a.normals, b.normals)
        # Into the caller's arrays, which start with other contents.
        oa, ob = np.full((nv, 3), np.nan), np.full((nv, 3), 7.0)
        na, nb = (np.full((nv, 3), -1.0), np.zeros((nv, 3))) if kw.get("normals") else (None, None)
        dev.deform(**kw, out=oa, out_normals=na)
        host.deform(**kw, out=ob, out_normals=nb)
        same_bits(oa, a.vertices)
        same_bits(ob, a.vertices)
        if na is not None:
            same_bits(na, nb)
            same_bits(na, a.normals)
    same_bits(dev._vk.vertices(), host._vk.vertices())


def test_one_mesh(monkeypatch, precision):
    mesh = shapes.icosphere(3)
    lat = vpffd.Lattice.around(mesh, shape=(5, 6, 5), degree=3)
    dev, host = both(monkeypatch, mesh, lat, precision)
    assert dev._vk.vertex_order.tolist() != list(range(mesh.n_vertices))  # a reorder to undo
    same_bits(dev._vk.vertices(), host._vk.vertices())  # the rest positions, before any frame
    compare(dev, host, lat, mesh.n_vertices)
    # After moves: the embedding changes, the slots stay.
    X = mesh.vertices * 0.9 + [0.05, -0.02, 0.01]
    for d in (dev, host):
        d.set_rest_vertices(X)
    compare(dev, host, lat, mesh.n_vertices)
    for d in (dev, host):
        d.set_rest_offsets([0.02, 0.0, -0.03])
    compare(dev, host, lat, mesh.n_vertices)


def test_parts(monkeypatch, precision):
    mesh, labels = spheres(3)
    lat = vpffd.Lattice.around(mesh, shape=(8, 4, 4), degree=3)
    dev, host = both(monkeypatch, mesh, lat, precision, parts=labels)
    compare(dev, host, lat, mesh.n_vertices)


@pytest.mark.parametrize("seam", ["shift", "twist"])
def test_periodic(monkeypatch, precision, seam):
    lo, hi = np.array([0.0, -0.5, -0.4]), np.array([2.0, 0.5, 0.4])
    lat = vpffd.Lattice(lo, hi, shape=(7, 5, 4), degree=3, periodic="x", seam=seam)
    m = shapes.icosphere(3, 0.3)
    mesh = vpffd.Mesh(m.vertices + [1.85, 0.0, 0.0], m.faces)  # across the seam
    dev, host = both(monkeypatch, mesh, lat, precision)
    compare(dev, host, lat, mesh.n_vertices)


def test_bad_setting(monkeypatch):
    monkeypatch.setenv("VPFFD_VULKAN_READBACK", "gpu")
    mesh = shapes.icosphere(1)
    with pytest.raises(vpffd.InvalidInputError, match="VPFFD_VULKAN_READBACK: expected 'device'"):
        vpffd.Deformer(mesh, vpffd.Lattice.around(mesh, shape=4), backend="vulkan", device=SEL)


def test_results_are_never_overwritten(precision):
    """Without out= the vertices are the read-back memory itself: a held result (or a
    view of it) keeps its values through later frames and after the deformer is gone;
    memory nobody holds any more is used again."""
    import gc
    mesh = shapes.icosphere(3)
    lat = vpffd.Lattice.around(mesh, shape=(5, 5, 5), degree=3)
    d = vpffd.Deformer(mesh, lat, backend="vulkan", device=SEL, gpu_precision=precision)
    Ps = [edits.squash(lat.control_points, f) for f in (0.7, 0.8, 0.9, 1.1, 1.2, 0.75)]
    ref = [d.deform(P).vertices.copy() for P in Ps]
    held = [d.deform(P).vertices for P in Ps[:4]]  # more than the deformer keeps: the last copies
    view = d.deform(Ps[4]).vertices[1::2]
    for _ in range(3):
        d.deform(Ps[5])
    for a, b in zip(held, ref):
        same_bits(a, b)
    same_bits(view, ref[4][1::2])
    assert len({a.__array_interface__["data"][0] for a in held}) == 4
    # A result let go of: its memory serves a later frame.
    addr = held[0].__array_interface__["data"][0]
    del held[0]
    gc.collect()
    again = d.deform(Ps[5]).vertices
    assert again.__array_interface__["data"][0] == addr
    same_bits(again, ref[5])
    del d
    gc.collect()
    same_bits(view, ref[4][1::2])  # the memory outlives the deformer
    same_bits(held[-1], ref[3])
