"""Exact foot points on the smooth base, the fitted base, and multiresolution edits of
real scans that turn no face over (paper 002, eq. 1 and §4.1).

Meshes made in code (a bumpy sphere, a noisy torus of genus 1) test everything in a
user's clone; the repository's closed scans (armadillo, horse, bunny) test where
foot points used to fail: thin parts, high curvature and noise.
"""
import numpy as np
import pytest

import vpffd
from vpffd.normals import angles_deg, vertex_normals
from test_vulkan import DEVICE

# Foot points: Newton's steps stop at rounding (~1e-16 of the coordinates); the
# contract is 1e-9 of the bounding-box diagonal (fitting.h's kFootPointTolerance).
FOOT = 1e-9
# Identity and rigid motions: p' = S'(t) + d N' is a short sum of O(1) products of
# coordinates, a few ulp each: ~1e-14 of the diagonal; 1e-12 leaves a factor 100.
EXACT = 1e-12


def _diag(V):
    return float(np.linalg.norm(np.ptp(V, axis=0)))


def noisy_torus(n_major=96, n_minor=32, R=1.0, r=0.3, noise=0.01, seed=3):
    """A torus (genus 1) with vertex noise along the normal: the details of a scan."""
    i, j = np.meshgrid(np.arange(n_major), np.arange(n_minor), indexing="ij")
    a, b = 2 * np.pi * i / n_major, 2 * np.pi * j / n_minor
    rng = np.random.default_rng(seed)
    rr = r + noise * rng.standard_normal(a.shape)
    V = np.stack([(R + rr * np.cos(b)) * np.cos(a), (R + rr * np.cos(b)) * np.sin(a), rr * np.sin(b)], -1)
    idx = lambda i, j: (i % n_major) * n_minor + (j % n_minor)  # noqa: E731
    F = []
    for ii in range(n_major):
        for jj in range(n_minor):
            q = [idx(ii, jj), idx(ii + 1, jj), idx(ii + 1, jj + 1), idx(ii, jj + 1)]
            F += [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
    return vpffd.Mesh(V.reshape(-1, 3), np.array(F, np.int32))


@pytest.fixture(scope="module", params=["bumpy_sphere", "noisy_torus"])
def made(request):
    mesh = vpffd.shapes.bumpy_sphere(4) if request.param == "bumpy_sphere" else noisy_torus()
    return mesh, vpffd.Multires(mesh)


def _check_eq1(mr, tol):
    """Eq. 1 recomputed here from the base alone: the foot point S(t) lies in its
    triangle, and p - S(t) is parallel to the interpolated unit vertex normal there."""
    F = mr.mesh.faces
    B = mr.base.vertices
    NB = vertex_normals((B, F))
    fd = mr.frame_data()
    f, uv = fd["foot_faces"], fd["foot_uv"]
    w = np.column_stack([1 - uv[:, 0] - uv[:, 1], uv[:, 0], uv[:, 1]])
    S = np.einsum("vk,vkc->vc", w, B[F[f]])
    N = np.einsum("vk,vkc->vc", w, NB[F[f]])
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    r = mr.mesh.vertices - S
    tangential = np.linalg.norm(r - (r * N).sum(1)[:, None] * N, axis=1)
    ex = mr.exact
    assert (w[ex] >= -1e-9).all(), "an exact foot point outside its triangle"
    assert tangential[ex].max() <= tol * _diag(mr.mesh.vertices)
    # A lifted vertex keeps (1 - w) of its displacement (the rest goes to the base map).
    np.testing.assert_allclose(mr.displacements[ex], ((1 - mr.lift) * (r * N).sum(1))[ex], rtol=0,
                               atol=tol * _diag(mr.mesh.vertices))
    return tangential


def test_foot_points_are_exact_on_meshes_made_in_code(made):
    mesh, mr = made
    assert mr.n_unresolved == 0 and mr.exact.all() and mr.unresolved.size == 0
    _check_eq1(mr, FOOT)
    assert mr.residuals.max() <= FOOT * _diag(mesh.vertices)
    assert "all resolved" in repr(mr) and "fitted 4x" in repr(mr)


def test_fitting_shortens_the_displacements(made):
    mesh, mr = made
    faired = vpffd.Multires(mesh, fit_rounds=0)
    assert len(mr.rms_displacement) == 5 and len(faired.rms_displacement) == 1
    assert mr.rms_displacement[0] == pytest.approx(faired.rms_displacement[0], rel=1e-12)
    # The fit's objective is the distance of the foot points to the vertices, |d|.
    assert mr.rms_displacement[-1] < 0.5 * mr.rms_displacement[0]
    np.testing.assert_allclose(np.sqrt(np.mean(mr.displacements ** 2)), mr.rms_displacement[-1], rtol=1e-12)
    assert "not fitted" in repr(faired)
    # The fitted base stays a base: smoother than the mesh (thin-plate fairness).
    assert np.linalg.norm(_umbrella(mr.base)) < 0.7 * np.linalg.norm(_umbrella(mesh))


def _umbrella(m):
    V, F = m.vertices, m.faces
    acc = np.zeros_like(V)
    deg = np.zeros(len(V))
    for a, b in [(0, 1), (1, 2), (2, 0)]:
        np.add.at(acc, F[:, a], V[F[:, b]])
        np.add.at(deg, F[:, a], 1)
    return V - acc / deg[:, None]


def test_identity_and_rigid_motions_are_exact(made):
    mesh, mr = made
    lat = vpffd.Lattice.around(mesh, shape=6)
    md = vpffd.MultiresDeformer(mr, lat)
    r = md.deform(lat.control_points, preserve_volume=False)
    assert np.abs(r.vertices - mesh.vertices).max() <= EXACT * _diag(mesh.vertices)
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    t = np.array([0.3, -0.2, 0.5])
    P = lat.control_points @ R.T + t
    r = md.deform(P, preserve_volume=False)
    assert np.abs(r.vertices - (mesh.vertices @ R.T + t)).max() <= EXACT * _diag(mesh.vertices)


def test_affine_foot_points_remain_available(made):
    mesh, _ = made
    mr = vpffd.Multires(mesh, fit_rounds=0, foot_points="affine")
    assert mr.n_unresolved == mesh.n_vertices  # no exact foot point claimed
    assert "affine foot points" in repr(mr)


@pytest.mark.parametrize("kwargs, message", [
    ({"fit_rounds": -1}, "fit_rounds"), ({"fit_rounds": 101}, "fit_rounds"), ({"fit_rounds": 2.0}, "fit_rounds"),
    ({"fairness": 0}, "fairness"), ({"fairness": float("nan")}, "fairness"),
    ({"foot_points": "closest"}, "foot_points")])
def test_bad_options_are_refused(kwargs, message):
    mesh = vpffd.shapes.bumpy_sphere(2)
    V = mesh.vertices.copy()
    with pytest.raises(vpffd.InvalidInputError, match=message):
        vpffd.Multires(mesh, **kwargs)
    np.testing.assert_array_equal(mesh.vertices, V)


# --- real scans ------------------------------------------------------------------

def face_normals(V, F):
    return np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])


def turned_faces(rest, deformed, F, J):
    """Faces whose deformed normal points against the space map's image of their rest
    normal, cof(J) n0 (J averaged over the face's corners): turned over, as opposed to
    merely rotated by the edit (a 90 degree twist rotates normals by 90 degrees)."""
    Jf = J[F].mean(axis=1)
    cof = np.linalg.inv(Jf).transpose(0, 2, 1) * np.linalg.det(Jf)[:, None, None]
    expected = np.einsum("fij,fj->fi", cof, face_normals(rest, F))
    return int(((expected * face_normals(deformed, F)).sum(1) < 0).sum())


EDITS = {
    "twist90": lambda P: vpffd.twist(P, 90),
    "bend45": lambda P: vpffd.bend(P, 45),
    "squash60": lambda P: vpffd.squash(P, 0.6),
}
SCANS = ["armadillo.ply", "horse.ply", "bunny_watertight.ply", "dragon_vrip_welded.ply.gz"]


@pytest.fixture(scope="module", params=SCANS)
def scan(request, shared_meshes):
    mesh = vpffd.load_mesh(shared_meshes / request.param)
    lat = vpffd.Lattice.around(mesh, shape=8)
    return request.param, mesh, lat, vpffd.Multires(mesh), vpffd.Deformer(mesh, lat)


def test_scan_foot_points(scan):
    name, mesh, lat, mr, _ = scan
    tangential = _check_eq1(mr, FOOT)
    # Vertices with no exact foot point are few and reported with their miss: 0 to 3
    # on the armadillo, horse and bunny, 503 of 435,545 (0.12 %) on the noisy dragon.
    assert mr.n_unresolved <= 0.002 * mesh.n_vertices, repr(mr)
    np.testing.assert_allclose(mr.residuals[mr.unresolved], tangential[mr.unresolved], rtol=1e-9,
                               atol=FOOT * _diag(mesh.vertices))
    assert mr.rms_displacement[-1] < 0.3 * mr.rms_displacement[0]


BACKENDS = ["serial"] + (["vulkan"] if DEVICE is not None else [])


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("edit", sorted(EDITS))
def test_scan_edits_turn_no_face(scan, edit, backend):
    name, mesh, lat, mr, plain = scan
    P = EDITS[edit](lat.control_points)
    J = plain.jacobians(P)
    assert turned_faces(mesh.vertices, plain.ffd(P), mesh.faces, J) == 0  # the edit itself folds nothing
    kw = {"backend": "vulkan"} if backend == "vulkan" else {"backend": "serial"}
    r = vpffd.MultiresDeformer(mr, lat, **kw).deform(P, preserve_volume=False)
    assert turned_faces(mesh.vertices, r.vertices, mesh.faces, J) == 0, f"{name} {edit}"
    # Approximate normals (eqs. 6-7) against the rebuilt mesh's own normals.
    err = angles_deg(r.normals, vertex_normals((r.vertices, mesh.faces)))
    assert err.mean() <= 2.0, f"{name} {edit}: mean {err.mean():.2f} deg"


def test_scan_lift_is_local(scan):
    """The lift touches only vertices of faces that are not height fields over their
    foot triangles: 0.5 % (bunny) to 4.6 % (dragon) of a scan's vertices."""
    name, mesh, _, mr, _ = scan
    assert mr.n_lifted <= 0.06 * mesh.n_vertices, repr(mr)
    assert ((mr.lift >= 0) & (mr.lift <= 1)).all()
    assert mr.n_lifted == int((mr.lift > 0).sum())


def test_without_the_lift_the_dragon_turns_faces(shared_meshes):
    """The failure the lift removes: the dragon's slivers and out-of-order foot
    points turn faces over under a 90 degree twist when every displacement is kept.
    (If this stops failing, the scan tests above no longer show the lift works.)"""
    mesh = vpffd.load_mesh(shared_meshes / "dragon_vrip_welded.ply.gz")
    lat = vpffd.Lattice.around(mesh, shape=8)
    P = EDITS["twist90"](lat.control_points)
    J = vpffd.Deformer(mesh, lat).jacobians(P)
    kept = vpffd.Multires(mesh, lift=False)
    assert kept.n_lifted == 0
    r = vpffd.MultiresDeformer(kept, lat, backend="openmp").deform(P, preserve_volume=False)
    assert turned_faces(mesh.vertices, r.vertices, mesh.faces, J) > 10


def slivered_sphere(n=60, toward=0.97, offset=0.3, seed=7):
    """A bumpy sphere with n cap slivers: one corner of n faces moved to within 3 % of
    its opposite edge and off the surface by 0.3 edge lengths (a scan's noise)."""
    m = vpffd.shapes.bumpy_sphere(4)
    V, F = m.vertices.copy(), m.faces
    rng = np.random.default_rng(seed)
    nrm = vertex_normals(m)
    e = np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).mean()
    used = np.zeros(len(V), bool)
    for f in rng.permutation(len(F)):
        if used[F[f]].any():
            continue
        a, b, c = F[f]
        V[a] += toward * (0.5 * (V[b] + V[c]) - V[a]) + offset * e * rng.choice([-1, 1]) * nrm[a]
        used[F[f]] = True
        n -= 1
        if n == 0:
            break
    return vpffd.Mesh(V, F)


def test_lifted_vertices_keep_identity_and_rigid_motions_exact():
    mesh = slivered_sphere()
    mr, kept = vpffd.Multires(mesh), vpffd.Multires(mesh, lift=False)
    assert mr.n_lifted > 0 and kept.n_lifted == 0 and not kept.lift.any()
    assert "lifted" in repr(mr) and "lifted" not in repr(kept)
    # Only the displacements (and the foot points with them) change: d' = (1 - w) d.
    np.testing.assert_allclose(mr.displacements, (1 - mr.lift) * kept.displacements, rtol=0,
                               atol=1e-15 * _diag(mesh.vertices))
    assert (mr.lift[mr.displacements == kept.displacements] == 0).all()
    lat = vpffd.Lattice.around(mesh, shape=6)
    md = vpffd.MultiresDeformer(mr, lat, backend="serial")
    r = md.deform(lat.control_points, preserve_volume=False)
    assert np.abs(r.vertices - mesh.vertices).max() <= EXACT * _diag(mesh.vertices)
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    t = np.array([0.3, -0.2, 0.5])
    r = md.deform(lat.control_points @ R.T + t, preserve_volume=False)
    assert np.abs(r.vertices - (mesh.vertices @ R.T + t)).max() <= EXACT * _diag(mesh.vertices)
    with pytest.raises(vpffd.InvalidInputError, match="lift"):
        vpffd.Multires(mesh, lift="yes")


def test_affine_foot_points_turn_faces_on_the_armadillo(shared_meshes):
    """The failure the exact foot points and the fit remove: with the faces' own
    frames and the faired base, the armadillo's twist turns faces over. (If this
    stops failing, the scan tests above no longer show anything.)"""
    mesh = vpffd.load_mesh(shared_meshes / "armadillo.ply")
    lat = vpffd.Lattice.around(mesh, shape=8)
    P = EDITS["twist90"](lat.control_points)
    J = vpffd.Deformer(mesh, lat).jacobians(P)
    old = vpffd.Multires(mesh, fit_rounds=0, foot_points="affine")
    r = vpffd.MultiresDeformer(old, lat).deform(P, preserve_volume=False)
    assert turned_faces(mesh.vertices, r.vertices, mesh.faces, J) > 10


def test_decomposition_reports_progress(caplog):
    """progress(done, total) after each stage, the stages logged, and an exception in
    the callback stops the decomposition and reaches the caller."""
    mesh = vpffd.shapes.bumpy_sphere(2)
    calls = []
    with caplog.at_level("INFO", logger="vpffd"):
        vpffd.Multires(mesh, progress=lambda k, n: calls.append((k, n)))
    assert calls == [(k, 6) for k in range(1, 7)]  # faired base, 4 fit rounds, the lift
    assert "fit round 4 (5/6)" in caplog.text and "lift (6/6)" in caplog.text
    calls.clear()
    vpffd.Multires(mesh, fit_rounds=1, lift=False, progress=lambda k, n: calls.append((k, n)))
    assert calls == [(1, 2), (2, 2)]

    def stop(k, n):
        if k == 2:
            raise KeyboardInterrupt("stopped by the user")
    with pytest.raises(KeyboardInterrupt, match="stopped"):
        vpffd.Multires(mesh, progress=stop)
    with pytest.raises(vpffd.InvalidInputError, match="progress"):
        vpffd.Multires(mesh, progress=3)
