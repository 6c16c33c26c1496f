"""RBFDeformer's regions mode (paper 002 §6: deformable region, handle regions moved by
affine maps, deformation basis precomputed per vertex) against the general RBF
solve, and the general mode against scipy's RBFInterpolator."""
import numpy as np
import pytest

import vpffd

# As in test_multires.py: outputs are short sums of O(1) products, ~1e-14 of the
# diagonal; 1e-12 leaves a factor of 100 for the compiler and the solve's rounding.
EXACT = 1e-12


def _diag(V):
    return float(np.linalg.norm(np.ptp(V, axis=0)))


def _affine(A, t):
    T = np.eye(4)
    T[:3, :3] = A
    T[:3, 3] = t
    return T


def _rot(a, axis=(1.0, 2.0, 3.0)):
    k = np.asarray(axis) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K


def _terms_magnitude(H, w, X):
    """max over the rows of X of sum_j |phi_j(x)| |w_j|: the size of the terms an RBF
    evaluation sums (rbf.h's normalised coordinates: centred on the handles' mean,
    divided by their bounding-box diagonal)."""
    c, s = H.mean(axis=0), _diag(H)
    C, Xn = (H - c) / s, (X - c) / s
    out = 0.0
    for b in range(0, len(Xn), 512):
        phi = np.linalg.norm(Xn[b:b + 512, None] - C[None], axis=2) ** 3
        out = max(out, float((phi @ np.abs(w)).max()))
    return out


@pytest.fixture(scope="module")
def mesh():
    return vpffd.shapes.bumpy_sphere(4)  # 2,562 vertices


@pytest.fixture(scope="module")
def mr(mesh):
    return vpffd.Multires(mesh, smoothing=10)


@pytest.fixture(scope="module")
def painted(mesh):
    """Deformable z > -0.2, handle 1 the cap z > 0.7, handle 2 a patch on the +x side."""
    V = mesh.vertices
    x, z = V[:, 0], V[:, 2]
    deformable = z > -0.2
    h1 = np.flatnonzero(z > 0.7)
    h2 = np.flatnonzero((x > 0.6) & (z > 0) & (z < 0.5))
    return deformable, [h1, h2]


@pytest.fixture(scope="module")
def rd(mr, painted):
    deformable, handles = painted
    return vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=handles)


def test_inputs_are_copied(mr, painted):
    deformable, handles = painted
    d0, h0 = deformable.copy(), [h.copy() for h in handles]
    rd = vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=handles)
    np.testing.assert_array_equal(deformable, d0)
    for h, c in zip(handles, h0):
        np.testing.assert_array_equal(h, c)
    assert not rd.labels.flags.writeable and not rd.handles.flags.writeable


def test_identity_is_exact_and_fixed_vertices_keep_their_bits(rd, mr, mesh, painted):
    assert rd.mode == "regions" and rd.n_regions == 2
    r = rd.deform(transforms=[np.eye(4), np.eye(4)])
    V = mesh.vertices
    assert np.abs(r.vertices - V).max() <= EXACT * _diag(V)
    assert np.abs(r.normals - mr.rest_normals).max() <= EXACT
    np.testing.assert_array_equal(r.base_vertices, mr.base.vertices)
    fixed = ~painted[0]
    np.testing.assert_array_equal(r.vertices[fixed], V[fixed])
    np.testing.assert_array_equal(r.normals[fixed], mr.rest_normals[fixed])
    # Labels: -1 fixed, 0 free, k handle region k.
    assert (rd.labels[fixed] == -1).all()
    assert (rd.labels[painted[1][0]] == 1).all() and (rd.labels[painted[1][1]] == 2).all()
    # Constraint points: thinned handle vertices (labels 1, 2) and fixed ring ones (-1).
    assert rd.n_handles == len(rd.constraint_vertices)
    assert set(rd.labels[rd.constraint_vertices]) == {-1, 1, 2}
    np.testing.assert_array_equal(rd.handles, mr.base.vertices[rd.constraint_vertices])


def test_one_rigid_motion_of_every_constraint_moves_the_mesh_rigidly(mr, mesh, painted):
    # No fixed part (deformable = every vertex), both regions by the same motion: the
    # RBF's linear part reproduces it, so every vertex and normal moves rigidly.
    rd = vpffd.RBFDeformer(mr, handle_regions=painted[1])
    T = _affine(_rot(0.8), [0.3, -0.2, 0.5])
    r = rd.deform(transforms=np.stack([T, T]))
    V = mesh.vertices
    assert np.abs(r.vertices - (V @ T[:3, :3].T + T[:3, 3])).max() <= EXACT * _diag(V)
    assert np.abs(r.normals - mr.rest_normals @ T[:3, :3].T).max() <= EXACT


def test_precomputed_basis_equals_the_general_solve(rd, mr, mesh, painted):
    S = _rot(0.5) @ np.diag([1.3, 1.0, 0.8])
    T = np.stack([_affine(S, [0.1, 0.2, 0.4]), _affine(_rot(-0.3, (0, 1, 0)), [0.3, 0.0, -0.1])])
    T0 = T.copy()
    r = rd.deform(transforms=T)
    np.testing.assert_array_equal(T, T0)  # inputs never modified
    general = vpffd.RBFDeformer(mr, rd.handles)
    g = general.deform(rd.targets(T))
    free = rd.labels == 0
    scale = _diag(mesh.vertices)
    # Both paths sum H + 4 terms phi_j(x) w_j per point, and the weights of a dense
    # constraint set are large and cancel (here |w| up to ~2,000 for O(1) values),
    # so each rounds by ~eps * sum_j |phi_j(x) w_j| (the terms' magnitude S, not the
    # result's). 1e-12 relative to S; S is measured (normalised coordinates as rbf.h).
    S = _terms_magnitude(rd.handles, general._rbf.solve(rd.targets(T)).w,
                         mr.frame_data()["foot_points"][free])
    tol = EXACT * max(scale, S)
    assert np.abs(r.vertices[free] - g.vertices[free]).max() <= tol
    assert np.abs(r.normals[free] - g.normals[free]).max() <= tol / scale
    # Base vertices: the free ones, and the handle constraint points (r interpolates T_k there).
    moved = free.copy()
    moved[rd.constraint_vertices[rd.labels[rd.constraint_vertices] > 0]] = True
    assert np.abs(r.base_vertices[moved] - g.base_vertices[moved]).max() <= tol
    # Handle vertices move with their own map exactly; normals by its cofactor matrix.
    for k, idx in enumerate(painted[1]):
        A, t = T[k, :3, :3], T[k, :3, 3]
        assert np.abs(r.vertices[idx] - (mesh.vertices[idx] @ A.T + t)).max() <= EXACT * scale
        n = mr.rest_normals[idx] @ (np.linalg.det(A) * np.linalg.inv(A))  # rows: cof(A) n
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        assert np.abs(r.normals[idx] - n).max() <= EXACT
    np.testing.assert_allclose(np.linalg.norm(r.normals, axis=1), 1.0, atol=1e-14)
    # Something really moved, smoothly: free vertices next to the cap moved up.
    assert np.abs(r.vertices - mesh.vertices).max() > 0.1


def test_labels_masks_and_index_lists_give_the_same_deformer(mr, painted):
    deformable, (h1, h2) = painted
    labels = np.zeros(mr.n_vertices, np.int64)
    labels[h1], labels[h2] = 1, 2
    mask2 = np.zeros(mr.n_vertices, bool)
    mask2[h2] = True
    T = np.stack([_affine(np.eye(3), [0, 0, 0.3]), _affine(_rot(0.2), [0.1, 0, 0])])
    a = vpffd.RBFDeformer(mr, deformable=deformable.astype(np.int8), handle_regions=labels).deform(transforms=T)
    b = vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=[h1, mask2]).deform(transforms=T)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.normals, b.normals)


def test_general_mode_positions_match_scipy(mr, mesh):
    scipy_interp = pytest.importorskip("scipy.interpolate")
    V = mr.base.vertices
    H = V[::40]
    rng = np.random.default_rng(3)
    T = H + 0.05 * rng.standard_normal(H.shape)
    rbf = vpffd.RBFDeformer(mr, H)
    ours = rbf.deform(T).base_vertices
    ref = scipy_interp.RBFInterpolator(H, T, kernel="cubic", degree=1)(V)
    # Same interpolant; two different solves of an O(1e6)-conditioned system.
    assert np.abs(ours - ref).max() <= 1e-9 * _diag(V)


def test_bad_input(mr, mesh, painted, rd):
    deformable, (h1, h2) = painted
    n = mr.n_vertices
    err = vpffd.InvalidInputError
    with pytest.raises(err, match=f"shape \\({n},\\)"):
        vpffd.RBFDeformer(mr, deformable=deformable[:-1], handle_regions=[h1])
    with pytest.raises(err, match="deformable region is empty"):
        vpffd.RBFDeformer(mr, deformable=np.zeros(n, bool), handle_regions=[h1])
    with pytest.raises(err, match="must not overlap"):
        vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=[h1, np.append(h2, h1[0])])
    with pytest.raises(err, match="handle region 2 is empty"):
        vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=[h1, []])
    with pytest.raises(err, match="outside the deformable region"):
        vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=[np.append(h1, np.flatnonzero(~deformable)[0])])
    with pytest.raises(err, match="no vertex is left"):
        vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=[np.flatnonzero(deformable)])
    with pytest.raises(err, match="mask"):
        vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=[h1, np.ones(n - 1, bool)])
    with pytest.raises(err, match="fixed_rings"):
        vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=[h1], fixed_rings=-1)
    with pytest.raises(err, match="not both"):
        vpffd.RBFDeformer(mr, mesh.vertices[::100], handle_regions=[h1])
    I = np.eye(4)
    singular = np.eye(4)
    singular[1, 1] = 0.0
    with pytest.raises(err, match="handle region 2 is singular"):
        rd.deform(transforms=[I, singular])
    proj = np.eye(4)
    proj[3, 2] = 0.5
    with pytest.raises(err, match="handle region 1 is not affine"):
        rd.deform(transforms=[proj, I])
    with pytest.raises(err, match="2 affine maps"):
        rd.deform(transforms=I)
    with pytest.raises(err, match="NaN"):
        rd.deform(transforms=[np.full((4, 4), np.nan), I])
    with pytest.raises(err, match="transforms"):
        rd.deform()
    with pytest.raises(err, match="not targets"):
        rd.deform(rd.handles)
    with pytest.raises(err, match="general mode"):
        rd.map(mesh.vertices, rd.handles)
    general = vpffd.RBFDeformer(mr, mesh.vertices[::100])
    with pytest.raises(err, match="regions mode"):
        general.deform(transforms=I)


def test_thread_count_does_not_change_frames(mr, painted):
    deformable, handles = painted
    T = np.stack([_affine(_rot(0.3), [0, 0, 0.2]), _affine(np.eye(3) * 1.1, [0.1, 0, 0])])
    a = vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=handles, threads=1).deform(transforms=T)
    b = vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=handles, threads=2).deform(transforms=T)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.normals, b.normals)
    H = mr.base.vertices[::60]
    g1 = vpffd.RBFDeformer(mr, H, threads=1).deform(H * 1.05)
    g2 = vpffd.RBFDeformer(mr, H, threads=2).deform(H * 1.05)
    np.testing.assert_array_equal(g1.vertices, g2.vertices)
    np.testing.assert_array_equal(g1.normals, g2.normals)


def test_spacing_thins_the_constraints(mr, painted):
    deformable, handles = painted
    every = vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=handles, spacing=0)
    assert every.n_handles == len(every.constraint_vertices)
    wide = vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=handles, spacing=0.15)
    assert 4 <= wide.n_handles < every.n_handles
    P = wide.handles
    regions = wide.labels[wide.constraint_vertices]
    for k in (-1, 1, 2):  # within one group no two constraint points closer than the spacing
        Q = P[regions == k]
        d = np.linalg.norm(Q[:, None] - Q[None], axis=2) + np.eye(len(Q)) * 1e9
        assert d.min() >= 0.15
    # Handle vertices still move with their map, all of them.
    T = np.stack([_affine(np.eye(3), [0, 0, 0.2]), np.eye(4)])
    r = wide.deform(transforms=T)
    np.testing.assert_allclose(r.vertices[handles[0]], mr.mesh.vertices[handles[0]] + [0, 0, 0.2], rtol=0,
                               atol=1e-15)
    with pytest.raises(vpffd.InvalidInputError, match="spacing"):
        vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=handles, spacing=-1.0)


def test_a_scanned_head_moved_by_a_handle(shared_meshes):
    # The armadillo's head (dense, uneven scan vertices): refused as singular with
    # every vertex a constraint, solved with the default spacing (one mean edge).
    mesh = vpffd.load_mesh(shared_meshes / "armadillo.ply")
    mr = vpffd.Multires(mesh, smoothing=10)
    V = mesh.vertices
    y = (V[:, 1] - V[:, 1].min()) / np.ptp(V[:, 1])
    deformable, head = y > 0.62, [np.flatnonzero(y > 0.92)]
    # (On the faired base: the fitted one follows the scan, whose constraint matrix
    # at spacing 0 happens to stay just within the solver's conditioning bound.)
    faired = vpffd.Multires(mesh, smoothing=10, fit_rounds=0)
    with pytest.raises(vpffd.SolverError, match="larger spacing"):
        vpffd.RBFDeformer(faired, deformable=deformable, handle_regions=head, spacing=0)
    rd = vpffd.RBFDeformer(mr, deformable=deformable, handle_regions=head)
    r = rd.deform(transforms=np.eye(4))
    assert np.abs(r.vertices - V).max() <= EXACT * _diag(V)
    T = _affine(_rot(0.4, (0, 0, 1)), [0.05 * _diag(V), 0, 0])
    r = rd.deform(transforms=T)
    g = vpffd.RBFDeformer(mr, rd.handles).deform(rd.targets(T))
    free = rd.labels == 0
    S = _terms_magnitude(rd.handles, vpffd.RBFDeformer(mr, rd.handles)._rbf.solve(rd.targets(T)).w,
                         mr.frame_data()["foot_points"][free])
    assert np.abs(r.vertices[free] - g.vertices[free]).max() <= EXACT * max(_diag(V), S)
    assert np.abs(r.vertices - V)[~deformable].max() == 0.0
