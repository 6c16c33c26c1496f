"""A moving scene (Scene(refit=True) + set_vertices): the refitted BVH gives the
hits of a scene built from the moved mesh, renders draw the moved mesh, and bad
vertices leave the scene as it was.

Why refitted and fresh scenes agree: Embree's only float32 inputs are the rays
and the vertex buffer, and both scenes hold the same buffer (the normalised
frame is computed from the same double vertices and rounded the same way). The
robust triangle test depends on the ray and the triangle's three float corners
only, so every triangle is hit or missed at the same float distance in both;
the BVH only decides which triangles are tested, never the result, and the
closest hit is the minimum over the hit triangles. Only a tie (a ray through an
edge or vertex shared by faces at equal distance) may resolve to another face,
and there the hit lies on the shared edge, so the faces share a vertex and the
points agree to Embree's float32 error: about 8 uf |coordinates| of the
normalised frame ([-1, 1]^3, uf = 2^-24), i.e. 1e-6 of the box, times the
1/cos of the incidence angle; 1e-4 of the box allows grazing rays. Everything
after Embree (the double refinement, shading) is a function of the face and the
ray, so faces that agree give bit-identical hits and pixels.
"""
import numpy as np
import pytest

import vpffd

pytestmark = pytest.mark.skipif(not vpffd._core.has_embree, reason="built without Embree")


@pytest.fixture(scope="module")
def moved():
    mesh = vpffd.shapes.icosphere(4)
    lat = vpffd.Lattice.around(mesh, shape=(5, 5, 5))
    P = vpffd.edits.twist(vpffd.edits.squash(lat.control_points, 0.6), 1.2)
    r = vpffd.Deformer(mesh, lat).deform(P, axes="xy")
    return mesh, vpffd.Mesh(r.vertices, mesh.faces)


def random_rays(n, seed=1):
    rng = np.random.default_rng(seed)
    O = rng.normal(size=(n, 3))
    O = 4 * O / np.linalg.norm(O, axis=1)[:, None]
    return O, rng.normal(size=(n, 3)) * 0.3 - O  # towards the mesh, spread over it


def assert_same_hits(a, b, faces, box):
    hit_a, face_a, bary_a, dist_a, point_a = a
    hit_b, face_b, bary_b, dist_b, point_b = b
    np.testing.assert_array_equal(hit_a, hit_b)
    same = hit_a & (face_a == face_b)
    np.testing.assert_array_equal(point_a[same], point_b[same])
    np.testing.assert_array_equal(dist_a[same], dist_b[same])
    np.testing.assert_array_equal(bary_a[same], bary_b[same])
    tie = hit_a & (face_a != face_b)
    for i in np.flatnonzero(tie):  # a ray through a shared edge or vertex
        assert set(faces[face_a[i]]) & set(faces[face_b[i]]), f"ray {i}: faces {face_a[i]}, {face_b[i]} not adjacent"
        assert np.linalg.norm(point_a[i] - point_b[i]) <= 1e-4 * box
    assert hit_a.mean() > 0.3  # the rays do reach the mesh


@pytest.mark.parametrize("fresh_refit", [True, False], ids=["fresh-refit-scene", "fresh-default-scene"])
def test_refitted_scene_hits_as_a_fresh_one(moved, fresh_refit):
    rest, m = moved
    s = vpffd.Scene(rest, refit=True)
    s.set_vertices(m.vertices)
    np.testing.assert_array_equal(s.mesh.vertices, m.vertices)
    fresh = vpffd.Scene(m, refit=fresh_refit)
    box = np.linalg.norm(np.ptp(m.vertices, axis=0))
    O, D = random_rays(20000)
    assert_same_hits(s.pick_many(O, D), fresh.pick_many(O, D), m.faces, box)
    # Rays through the corners of faces: the ties, where only the face may differ.
    f = m.faces[::7]
    corners = m.vertices[f[:, 0]]
    O2 = corners + 3.0 * (corners - corners.mean(axis=0))
    assert_same_hits(s.pick_many(O2, corners - O2), fresh.pick_many(O2, corners - O2), m.faces, box)


def test_refitted_scene_renders_as_a_fresh_one(moved):
    rest, m = moved
    s = vpffd.Scene(rest, refit=True)
    cam = vpffd.Camera((2, -3, 1.5), (0, 0, 0))
    kw = dict(size=(160, 120), samples=2, colors=rest.vertices[:, 2], return_depth=True)
    first = vpffd.render(s, cam, **kw)[0]  # the scene's shading normals are made for the rest mesh ...
    assert np.abs(first.astype(int) - vpffd.render(rest, cam, **kw)[0]).max() <= 1  # (ties: see below)
    s.set_vertices(m.vertices)  # ... and must be remade for the moved one
    img_refit, depth_refit = vpffd.render(s, cam, **kw)
    img, depth = vpffd.render(m, cam, **kw)
    # Same faces give identical pixels; a tie gives the other face's shading at
    # the same point, equal up to float rounding of the interpolation: one level.
    assert np.abs(img_refit.astype(int) - img).max() <= 1
    np.testing.assert_array_equal(np.isfinite(depth_refit), np.isfinite(depth))
    fin = np.isfinite(depth)
    assert fin.mean() > 0.2
    np.testing.assert_allclose(depth_refit[fin], depth[fin], rtol=1e-6)
    # ... and not the rest mesh's picture: the scene did move (squashed to 0.6 in z).
    _, depth_rest = vpffd.render(rest, cam, **kw)
    assert (np.isfinite(depth_rest) != fin).mean() > 0.05


def test_moving_back_and_forth(moved):
    rest, m = moved
    s = vpffd.Scene(rest, refit=True)
    O, D = random_rays(3000, seed=2)
    before = s.pick_many(O, D)
    s.set_vertices(m.vertices)
    assert not np.array_equal(s.pick_many(O, D)[4], before[4])
    s.set_vertices(rest.vertices)
    for x, y in zip(s.pick_many(O, D), before):
        np.testing.assert_array_equal(x, y)
    # A scene without refit moves too (rebuilt).
    plain = vpffd.Scene(rest)
    plain.set_vertices(m.vertices)
    box = np.linalg.norm(np.ptp(m.vertices, axis=0))
    assert_same_hits(plain.pick_many(O, D), vpffd.Scene(m).pick_many(O, D), m.faces, box)


def test_moved_far_and_scaled(moved):
    """The normalised frame follows the mesh: a move far away and a rescale keep the hits."""
    rest, m = moved
    s = vpffd.Scene(rest, refit=True)
    V = m.vertices * 1e6 + [3e9, -1e9, 5e8]
    s.set_vertices(V)
    far = vpffd.Mesh(V, m.faces)
    O, D = random_rays(2000, seed=3)
    O = O * 1e6 + [3e9, -1e9, 5e8]
    assert_same_hits(s.pick_many(O, D), vpffd.Scene(far).pick_many(O, D), m.faces, 1e6 * 4)


def test_bad_vertices_leave_the_scene_unchanged(moved):
    rest, m = moved
    s = vpffd.Scene(rest, refit=True)
    O, D = random_rays(500, seed=4)
    before = s.pick_many(O, D)
    bad = m.vertices.copy()
    bad[17, 1] = np.nan
    with pytest.raises(vpffd.InvalidInputError, match="row 17"):
        s.set_vertices(bad)
    with pytest.raises(vpffd.InvalidInputError, match="rows"):
        s.set_vertices(m.vertices[:-1])
    with pytest.raises(vpffd.InvalidInputError):
        s._s.set_vertices(bad)  # the C++ check, behind the Python one
    with pytest.raises(vpffd.InvalidInputError, match="vertices for a scene of"):
        s._s.set_vertices(m.vertices[:-1])
    for x, y in zip(s.pick_many(O, D), before):
        np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(s.mesh.vertices, rest.vertices)


def test_caller_array_copied(moved):
    rest, m = moved
    s = vpffd.Scene(rest, refit=True)
    V = m.vertices.copy()
    s.set_vertices(V)
    O, D = random_rays(500, seed=5)
    hits = s.pick_many(O, D)
    V[:] = 0.0  # the caller's later writes do not reach the scene
    for x, y in zip(s.pick_many(O, D), hits):
        np.testing.assert_array_equal(x, y)
    assert not s.mesh.vertices.flags.writeable
