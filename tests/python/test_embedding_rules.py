"""The embedding's two rules (lattice/embed.h: accepted_box, accepted_parameters) hold
alike on every backend, at construction and for rest moves: a point within 1e-12 of the
box's extent outside a face is inside; a point past 1000 domain widths is refused even
where outside points are extrapolated."""
import numpy as np
import pytest

import vpffd
from test_threads import BACKENDS, backend_kwargs


def _setup():
    mesh = vpffd.shapes.icosphere(2)
    lat = vpffd.Lattice(np.array([-1.0, -1.0, -1.0]), np.array([1.0, 1.0, 1.0]), shape=4)
    return mesh, lat


def _vertex_at(mesh, x):
    V = mesh.vertices.copy()
    i = int(np.argmax(V[:, 0]))
    V[i, 0] = x
    return V


@pytest.mark.parametrize("backend", BACKENDS)
def test_box_faces_take_the_tolerance_and_no_more(backend):
    mesh, lat = _setup()
    kw = backend_kwargs(backend)
    d = vpffd.Deformer(mesh, lat, **kw)
    extent = lat.box_max[0] - lat.box_min[0]
    # 0.5e-12 of the extent past the face: inside by the rule (the rounding of a
    # box around a mesh); 4e-12: outside, refused under outside="error".
    inside = _vertex_at(mesh, lat.box_max[0] + 0.5e-12 * extent)
    outside = _vertex_at(mesh, lat.box_max[0] + 4e-12 * extent)
    vpffd.Deformer(vpffd.Mesh(inside, mesh.faces), lat, **kw)
    d.set_rest_vertices(inside)
    with pytest.raises(vpffd.InvalidInputError, match="outside"):
        vpffd.Deformer(vpffd.Mesh(outside, mesh.faces), lat, **kw)
    with pytest.raises(vpffd.InvalidInputError, match="outside"):
        d.set_rest_vertices(outside)
    np.testing.assert_array_equal(d.rest_vertices, inside)  # a refused move changes nothing


@pytest.mark.parametrize("backend", BACKENDS)
def test_far_points_are_refused_even_when_extrapolating(backend):
    mesh, lat = _setup()
    kw = backend_kwargs(backend)
    d = vpffd.Deformer(mesh, lat, outside="extrapolate", **kw)
    width = lat.box_max[0] - lat.box_min[0]  # the domain's width in world units (clamped knots)
    near = _vertex_at(mesh, lat.box_max[0] + 999 * width)
    far = _vertex_at(mesh, lat.box_max[0] + 1001 * width)
    d.set_rest_vertices(near)
    with pytest.raises(vpffd.InvalidInputError, match="too far"):
        d.set_rest_vertices(far)
    with pytest.raises(vpffd.InvalidInputError, match="too far"):
        vpffd.Deformer(vpffd.Mesh(far, mesh.faces), lat, outside="extrapolate", **kw)
