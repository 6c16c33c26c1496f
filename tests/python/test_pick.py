"""Picking with Embree: expected faces, misses, pixels, and the hit as a constraint source."""
import numpy as np
import pytest

import vpffd

pytestmark = pytest.mark.skipif(not vpffd._core.has_embree, reason="built without Embree")


@pytest.fixture(scope="module")
def sphere():
    return vpffd.shapes.icosphere(3)


def brute_force(mesh, o, d):
    """Nearest ray-triangle hit (Moeller-Trumbore over every face): (face, t) or (None, inf)."""
    V, F = mesh.vertices, mesh.faces
    p0, e1, e2 = V[F[:, 0]], V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    h = np.cross(d, e2)
    a = np.einsum("ij,ij->i", e1, h)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = 1.0 / a
        s = o - p0
        u = f * np.einsum("ij,ij->i", s, h)
        q = np.cross(s, e1)
        v = f * (q @ d)
        t = f * np.einsum("ij,ij->i", e2, q)
    ok = (np.abs(a) > 1e-14) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    if not ok.any():
        return None, np.inf
    i = np.flatnonzero(ok)[np.argmin(t[ok])]
    return int(i), float(t[i])


def test_hit_from_above(sphere):
    h = vpffd.pick(sphere, (0, 0, 5), (0, 0, -1))
    assert h is not None
    assert h.distance == pytest.approx(5 - np.linalg.norm(h.point), abs=1e-12)
    assert np.linalg.norm(h.point) <= 1 + 1e-12 and h.point[2] > 0.99
    assert h.barycentric.sum() == pytest.approx(1.0)
    assert (h.barycentric >= -1e-9).all()
    np.testing.assert_allclose(h.point, h.barycentric @ sphere.vertices[sphere.faces[h.face]], atol=1e-14)


def test_expected_faces_on_random_rays(sphere):
    rng = np.random.default_rng(3)
    scene = vpffd.Scene(sphere)
    O = rng.normal(size=(200, 3))
    O = 3 * O / np.linalg.norm(O, axis=1, keepdims=True)
    D = rng.uniform(-0.4, 0.4, size=(200, 3)) - O / 3  # roughly towards the centre
    hit, face, bary, dist, point = scene.pick_many(O, D)
    n_hits = 0
    for i in range(len(O)):
        d = D[i] / np.linalg.norm(D[i])
        f_ref, t_ref = brute_force(sphere, O[i], d)
        assert hit[i] == (f_ref is not None)
        if f_ref is not None:
            n_hits += 1
            assert dist[i] == pytest.approx(t_ref, rel=1e-5)
            if face[i] != f_ref:  # only allowed on a shared edge: same point
                np.testing.assert_allclose(point[i], O[i] + t_ref * d, atol=1e-5)
    assert n_hits > 100


def test_miss_returns_none(sphere):
    assert vpffd.pick(sphere, (0, 0, 5), (0, 0, 1)) is None
    assert vpffd.pick(sphere, (3, 3, 3), (1, 0, 0)) is None


def test_inside_hits_the_shell(sphere):
    h = vpffd.pick(sphere, (0, 0, 0), (1, 0, 0))
    assert h is not None and 0.9 < h.distance <= 1.0


def test_pick_pixel_centre_and_corner(sphere):
    cam = vpffd.Camera.framing(sphere, size=(160, 120))
    h = vpffd.pick_pixel(sphere, cam, 80, 60, size=(160, 120))
    assert h is not None
    # The centre ray points at the target (the sphere's centre): the hit is the
    # point of the sphere facing the eye.
    toward_eye = (cam.eye - cam.target) / np.linalg.norm(cam.eye - cam.target)
    assert np.dot(h.point, toward_eye) > 0.97
    assert vpffd.pick_pixel(sphere, cam, 0, 0, size=(160, 120)) is None


def test_pick_pixel_agrees_with_render_depth(sphere):
    cam = vpffd.Camera.framing(sphere, size=(64, 48))
    _, depth = vpffd.render(sphere, cam, size=(64, 48), return_depth=True)
    scene = vpffd.Scene(sphere)
    for x, y in [(32, 24), (20, 30), (45, 10), (0, 0), (63, 47)]:
        h = scene.pick_pixel(cam, x, y, size=(64, 48))
        if h is None:
            assert np.isinf(depth[y, x])
        else:
            assert depth[y, x] == pytest.approx(h.distance, rel=1e-5)


def test_projection_round_trip(sphere):
    cam = vpffd.Camera.framing(sphere, size=(200, 100))
    h = vpffd.pick_pixel(sphere, cam, 110, 40, size=(200, 100))
    assert h is not None
    np.testing.assert_allclose(cam.project(h.point, size=(200, 100))[0], [110, 40], atol=1e-6)


def test_hit_as_constraint_source(sphere):
    """Pick on the deformed mesh, drag the hit point: the rest point is the
    constraint source (Problem 2), and the corrected lattice carries it to the target."""
    lat = vpffd.Lattice.around(sphere, shape=(5, 5, 5))
    d = vpffd.Deformer(sphere, lat)
    r0 = d.deform(vpffd.edits.twist(lat.control_points, 0.8))
    deformed = vpffd.Mesh(r0.vertices, sphere.faces)
    h = vpffd.pick(deformed, (0.2, -5, 0.3), (0, 1, 0))
    assert h is not None
    src = h.rest_point(sphere)
    np.testing.assert_allclose(lat.parameters(src[None])[0], h.lattice_parameter(lat, sphere))
    # The rest point maps close to the hit point (the surface is curved between vertices).
    image = lat.deform_points(src[None], r0.control_points)[0]
    assert np.linalg.norm(image - h.point) < 0.02
    target = image + [0, -0.15, 0]
    r = d.deform(r0.control_points, constraints=[(src, target)])
    assert r.constraint_error < 1e-9
    np.testing.assert_allclose(lat.deform_points(src[None], r.control_points)[0], target, atol=1e-9)
    assert r.volume == pytest.approx(sphere.volume, rel=1e-10)


def test_bad_arguments(sphere):
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.pick(sphere, (0, 0, 5), (0, 0, 0))
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.pick(sphere, (0, np.nan, 5), (0, 0, 1))
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.pick(sphere, (0, 0), (0, 0, 1))
    with pytest.raises(TypeError):
        vpffd.pick_pixel(sphere, "camera", 0, 0)
    with pytest.raises(TypeError):
        vpffd.pick("mesh", (0, 0, 5), (0, 0, -1))
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.Camera((0, 0, 0), (0, 0, 0))
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.Camera((0, 0, 5), (0, 0, 0), up=(0, 0, 1))  # up parallel to the view
    with pytest.raises(vpffd.InvalidInputError):
        vpffd.Camera((0, -5, 0), (0, 0, 0), fov=0)
    h = vpffd.pick(sphere, (0, 0, 5), (0, 0, -1))
    with pytest.raises(vpffd.InvalidInputError):
        h.rest_point(vpffd.Mesh(sphere.vertices, sphere.faces[:10]))


def test_concurrent_scenes_and_picks_from_threads(sphere):
    # All scenes share one Embree device; its errors are per thread, so calls
    # from several Python threads (the GIL is released in C++) must neither
    # disturb each other's results nor receive each other's errors.
    import threading
    rng = np.random.default_rng(11)
    O = rng.normal(size=(3000, 3))
    O = 3 * O / np.linalg.norm(O, axis=1, keepdims=True)
    D = -O
    ref = vpffd.Scene(sphere).pick_many(O, D)
    errors, results = [], []

    def work():
        try:
            for _ in range(3):
                results.append(vpffd.Scene(sphere).pick_many(O, D))
        except Exception as e:  # noqa: BLE001 - collected and reported below
            errors.append(e)

    threads = [threading.Thread(target=work) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    assert len(results) == 12
    for r in results:
        np.testing.assert_array_equal(r[0], ref[0])
        np.testing.assert_array_equal(r[1], ref[1])


def test_pick_many_empty():
    """No rays gave "pick: origins: is empty"; now empty results of the usual dtypes."""
    scene = vpffd.Scene(vpffd.shapes.icosphere(1))
    full = scene.pick_many(np.zeros((1, 3)), np.ones((1, 3)))
    for origins, directions in ((np.zeros((0, 3)), np.zeros((0, 3))), ([], [])):
        empty = scene.pick_many(origins, directions)
        assert len(empty) == len(full)
        for e, f in zip(empty, full):
            assert e.dtype == f.dtype and e.shape == (0,) + f.shape[1:]
    with pytest.raises(vpffd.InvalidInputError):
        scene.pick_many(np.zeros((0, 3)), np.zeros((1, 3)))
