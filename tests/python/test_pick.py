"""Picking with Embree: expected faces, misses, pixels, and the hit as a constraint source.

Error bounds used below (u = 2^-53, the double unit roundoff; uf = 2^-24, float32's).
Embree (float32) only chooses the face; the hit is recomputed in double by
Moeller-Trumbore on the double triangle in a frame normalised to [-1, 1]^3 by a
power of two, and the point is the barycentric combination of the double corners.
- Barycentrics: either MT's (b1, b2, 1 - b1 - b2), all checked >= 0, or a point
  of an edge ((1 - t, t, 0), t clamped to [0, 1]); so each is in [0, 1] exactly
  and their sum is 1 up to the one rounding of 1 - b1 - b2 and the summation: 3u.
- Point: sum_i w_i p_i with w_i >= 0: each coordinate has error <= 3u sum_i w_i |p_i|
  (two products and two sums, gamma_3), plus the weights' sum error 3u |p|; so
  the point's norm is at most max_i |p_i| (1 + 6u) + rounding of the norm (2u).
- Distance along the ray: MT's t has a relative error of a few u (about 20
  operations: call it 32u) times the condition number 1/cos(theta) of a
  ray-plane intersection (theta: angle between the ray and the face normal),
  relative to the coordinates' magnitude |o| + |p|; and the same again for the
  reference (brute-force MT here).
- Where Embree's float32 choice of face and the double ray disagree (the ray
  passes within Embree's error of an edge), the hit is snapped to that edge: the
  point then differs from the true one by at most Embree's error, about
  8 uf |coordinates| / cos(theta) in the normalised frame.
"""
import json
import subprocess
import sys

import numpy as np
import pytest

import vpffd

pytestmark = pytest.mark.skipif(not vpffd._core.has_embree, reason="built without Embree")
U = 2.0 ** -53   # double unit roundoff
UF = 2.0 ** -24  # float32 unit roundoff


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


def check_hit_is_double(mesh, h):
    """The bounds of the module docstring: barycentrics in [0, 1] summing to 1 (3u),
    point = barycentric combination of the double corners (3u |p| per coordinate,
    for both this and numpy's evaluation)."""
    assert (h.barycentric >= 0).all() and (h.barycentric <= 1).all(), h.barycentric
    assert abs(h.barycentric.sum() - 1.0) <= 3 * U
    corners = mesh.vertices[mesh.faces[h.face]]
    scale = np.abs(corners).max()
    np.testing.assert_allclose(h.point, h.barycentric @ corners, rtol=0, atol=12 * U * scale)


def test_hit_from_above(sphere):
    """Failed on an AVX2 AMD EPYC when Embree's float32 u, v were applied to the
    double corners: the point 5.2e-11 outside the sphere, barycentrics (1, -2.1e-9, -2.1e-9)."""
    h = vpffd.pick(sphere, (0, 0, 5), (0, 0, -1))
    assert h is not None
    check_hit_is_double(sphere, h)
    # |corners| <= 1 + 3u (normalised in double); the combination adds 6u, the norm 2u.
    assert np.linalg.norm(h.point) <= 1 + 11 * U and h.point[2] > 0.99
    # The ray is the z axis, met head-on (cos theta ~ 1): t has 32u relative to |o| = 5,
    # the reference 5 - |point| another 11u of |point| <= 1 and one rounding of 5.
    assert abs(h.distance - (5 - np.linalg.norm(h.point))) <= 32 * U * 6 + 11 * U + 5 * U


def test_expected_faces_on_random_rays(sphere):
    rng = np.random.default_rng(3)
    scene = vpffd.Scene(sphere)
    O = rng.normal(size=(200, 3))
    O = 3 * O / np.linalg.norm(O, axis=1, keepdims=True)
    D = rng.uniform(-0.4, 0.4, size=(200, 3)) - O / 3  # roughly towards the centre
    hit, face, bary, dist, point = scene.pick_many(O, D)
    V, F = sphere.vertices, sphere.faces
    normals = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    # The silhouette of the polyhedron lies between its faces' smallest distance
    # from the centre and 1: only rays passing there may be hit in float32 and
    # missed in double or the reverse.
    r_in = np.abs(np.einsum("ij,ij->i", normals, V[F[:, 0]])).min()
    n_hits = 0
    for i in range(len(O)):
        d = D[i] / np.linalg.norm(D[i])
        f_ref, t_ref = brute_force(sphere, O[i], d)
        if hit[i] != (f_ref is not None):
            r = np.linalg.norm(O[i] - (O[i] @ d) * d)
            assert r_in - 8 * UF <= r <= 1 + 8 * UF, (i, r)
            continue
        if f_ref is not None:
            n_hits += 1
            cos = abs(normals[f_ref] @ d)
            mag = np.linalg.norm(O[i]) + 1
            if face[i] == f_ref:  # both are MT in double on the same triangle
                assert abs(dist[i] - t_ref) <= 2 * 32 * U * mag / cos
            else:  # only on a shared edge: the same point up to Embree's error
                np.testing.assert_allclose(point[i], O[i] + t_ref * d, rtol=0, atol=8 * UF * mag / cos)
            assert (bary[i] >= 0).all() and abs(bary[i].sum() - 1) <= 3 * U
    assert n_hits > 100


def test_miss_returns_none(sphere):
    assert vpffd.pick(sphere, (0, 0, 5), (0, 0, 1)) is None
    assert vpffd.pick(sphere, (3, 3, 3), (1, 0, 0)) is None


def test_inside_hits_the_shell(sphere):
    """From the centre along +x the ray meets the vertex (1, 0, 0) of the icosphere,
    where six faces meet: whichever Embree picks, the double hit is that corner
    (or the point of an edge next to it), at distance 1 within the point bound
    (11u) plus MT's 32u (|o| = 0, |p| = 1, head-on)."""
    h = vpffd.pick(sphere, (0, 0, 0), (1, 0, 0))
    assert h is not None and 0.9 < h.distance <= 1.0 + 43 * U
    check_hit_is_double(sphere, h)
    np.testing.assert_allclose(h.point, [1, 0, 0], rtol=0, atol=43 * U)


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
    V, F = sphere.vertices, sphere.faces
    for x, y in [(32, 24), (20, 30), (45, 10), (0, 0), (63, 47)]:
        h = scene.pick_pixel(cam, x, y, size=(64, 48))
        if h is None:
            assert np.isinf(depth[y, x])
        else:
            # The render's depth is Embree's float32 distance, from a start inside the
            # normalised frame's sphere of radius 1.75 (coordinates <= 1.75 + 1.75),
            # rounded to float32: 8 uf * 3.5 / cos(theta) + uf * depth.
            n = np.cross(V[F[h.face, 1]] - V[F[h.face, 0]], V[F[h.face, 2]] - V[F[h.face, 0]])
            cos = abs(n @ cam.ray(x, y, (64, 48))[1]) / np.linalg.norm(n)
            assert abs(depth[y, x] - h.distance) <= 8 * UF * 3.5 / cos + UF * h.distance


def test_projection_round_trip(sphere):
    cam = vpffd.Camera.framing(sphere, size=(200, 100))
    h = vpffd.pick_pixel(sphere, cam, 110, 40, size=(200, 100))
    assert h is not None
    # The point is on the double ray within ~1e-14 world units (module docstring);
    # at about 100 pixels per unit that is 1e-12 pixels: 1e-6 is a wide margin.
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


# --- coordinates Embree (float32, origins below 1.8e18) cannot take as they are ---
def run_isolated(code):
    """Runs ``code`` in a fresh interpreter (an abort inside Embree must not kill the
    suite); returns what it printed as JSON."""
    r = subprocess.run([sys.executable, "-c", "import json, numpy as np, vpffd\n" + code],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, f"exit {r.returncode}: {r.stderr[-2000:]}"
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("scale", [1e-30, 1e18, 1e20, 1e150])
def test_scaled_meshes_pick_and_render(scale):
    """A mesh scaled by 1e18 aborted in Embree (ray.valid()), 1e19-1e20 rendered all
    white. Scaled by any factor, picking gives the unit mesh's hit times the scale:
    every step is scale-invariant up to the one rounding of each scaled coordinate
    (u), so the relative difference is within the point bound (11u) plus MT's
    (32u, head-on) on both: 100u. Renders agree except where a ray passes within
    float32 error of a silhouette (a few pixels of the ~300 on the outline)."""
    out = run_isolated(f"""
s = {scale!r}
unit = vpffd.shapes.icosphere(3)
big = vpffd.Mesh(unit.vertices * s, unit.faces)
res = {{}}
for name, m, k in (("unit", unit, 1.0), ("big", big, s)):
    h = vpffd.pick(m, (0.1 * k, 0.2 * k, 5 * k), (0, 0, -1))
    res[name] = [list(h.point / k), h.face, list(h.barycentric), h.distance / k]
    cam = vpffd.Camera.framing(m, size=(64, 48))
    res[name + "_img"] = vpffd.render(m, cam, size=(64, 48)).tolist()
print(json.dumps(res))
""")
    pu, fu, bu, du = out["unit"]
    pb, fb, bb, db = out["big"]
    np.testing.assert_allclose(pb, pu, rtol=0, atol=100 * U)
    assert abs(db - du) <= 100 * U * 6
    assert (np.array(bb) >= 0).all() and abs(sum(bb) - 1) <= 3 * U
    a, b = np.array(out["unit_img"]), np.array(out["big_img"])
    mask_a, mask_b = (a != 255).any(axis=2), (b != 255).any(axis=2)
    assert mask_a.mean() > 0.1  # not blank (Camera.framing fits the bounding sphere: ~15 %)
    assert (mask_a != mask_b).sum() <= 8


def test_far_ray_origins():
    """vpffd.pick(mesh, (0, 0, 1e20), (0, 0, -1)) aborted inside Embree. The origin is
    carried along the exact ray to the mesh in double: axis-aligned rays are exact
    from any distance; an oblique one from 1e20 is placed within ~u^2 D = 1e-12
    (hits the point facing it, within the icosphere's chord error); from 1e30 the
    placement error (~u^2 D = 1e-2) exceeds float32's grid and the ray is refused
    with a clear error, never a crash or a wrong hit."""
    out = run_isolated("""
m = vpffd.shapes.icosphere(3)
res = {}
for key, o, d in (("z20", (0, 0, 1e20), (0, 0, -1)), ("z300", (0, 0, 1e300), (0, 0, -1e-300)),
                  ("x308", (-1.7e308, 0, 0), (1, 0, 0)), ("diag20", (1e20, 1e20, 1e20), (-1, -1, -1)),
                  ("away", (0, 0, 1e20), (0, 0, 1)), ("passby", (5e20, 0, 1e20), (-1, 0, 0))):
    h = vpffd.pick(m, o, d)
    res[key] = None if h is None else [list(h.point), h.distance, list(h.barycentric)]
w = np.array([0.3, 0.5, 0.7])
try:  # exactly through the centre (2^100 w is exact), from 1e30
    h = vpffd.pick(m, w * 2.0 ** 100, -w)
    res["far"] = list(h.point)
except vpffd.InvalidInputError as e:
    res["far"] = str(e)
print(json.dumps(res))
""")
    # icosphere(3): faces' distance from the centre >= cos(largest circumradius angle) > 0.99
    for key, sign_axis in (("z20", (2, 1)), ("z300", (2, 1)), ("x308", (0, -1))):
        p, dist, bary = out[key]
        axis, sign = sign_axis
        assert 0.99 < sign * p[axis] <= 1 + 11 * U, key
        assert np.linalg.norm(np.delete(p, axis)) <= 11 * U, key
        assert (np.array(bary) >= 0).all() and abs(sum(bary) - 1) <= 3 * U
    assert out["z20"][1] == pytest.approx(1e20 - out["z20"][0][2], rel=4 * U)
    p = np.array(out["diag20"][0])
    np.testing.assert_allclose(p / np.linalg.norm(p), np.ones(3) / np.sqrt(3), atol=1e-9)
    assert 0.99 < np.linalg.norm(p) <= 1 + 11 * U
    assert out["away"] is None and out["passby"] is None
    # Refused unless this CPU's rounding happened to place the ray exactly; then a right hit.
    far = out["far"]
    if isinstance(far, str):
        assert "too far" in far
    else:
        np.testing.assert_allclose(np.array(far) / np.linalg.norm(far), [0.3, 0.5, 0.7] / np.linalg.norm([0.3, 0.5, 0.7]),
                                   atol=1e-6)
