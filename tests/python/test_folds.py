"""Fold-over certification (vpffd.check_folds), the on_fold modes of deform and
the automatic local correction weights (weights="auto")."""
import warnings

import numpy as np
import pytest

import vpffd
from vpffd import folds
from vpffd.animate import BouncingBall, Twist


def fd_det(lat, P, x, rel_step=1e-5):
    """det J at rest-space points x (n, 3) by central differences of the FFD.

    Step h = 1e-5 of the box extent: truncation O(h^2 |D'''|) ~ 1e-10 and rounding
    O(u |D| / h) ~ 1e-11 relative to |J| for the lattices here, so a det of
    magnitude > 1e-6 |J|^3 has the right sign."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    ext = lat.box_max - lat.box_min
    cols = []
    for a in range(3):
        h = rel_step * ext[a]
        e = np.zeros(3)
        e[a] = h
        Dp = lat.deform_points(x + e, P, outside="extrapolate")
        Dm = lat.deform_points(x - e, P, outside="extrapolate")
        cols.append((Dp - Dm) / (2 * h))
    return np.linalg.det(np.stack(cols, axis=2))


def grid_points(lat, n):
    t = (np.arange(n) + 0.5) / n
    g = np.stack(np.meshgrid(t, t, t, indexing="ij"), axis=-1).reshape(-1, 3)
    return lat.box_min + g * (lat.box_max - lat.box_min)


def swapped_slabs(lat, a=2, b=4):
    P = np.array(lat.rest_points)
    P[[a, b]] = P[[b, a]]
    return P


# --- certification -------------------------------------------------------------
@pytest.mark.parametrize("degree", [1, 2, 3, 5])
def test_identity_is_certified_with_det_one(degree):
    lat = vpffd.Lattice([0, 0, 0], [2, 1, 3], shape=degree + 3, degree=degree)
    rep = vpffd.check_folds(lat)
    assert rep.certified and not rep.folded and rep.witness is None
    assert rep.status.shape == (3, 3, 3) and (rep.status == folds.CERTIFIED).all()
    assert rep.n_refined == 0 and rep.n_subcells == 27
    # det J = 1; the lower bound is below by the rounding bound of rounding.h,
    # 12 gamma_K (M / D)^3 relative, with K < 1400 (gamma_K < 2e-13) and M / D, the
    # net's size over a Bezier edge, below 3 (d+1) times the box aspect ratio (3):
    # < 1e-6 for degree 5.
    assert rep.min_det == pytest.approx(1.0, abs=1e-12)
    assert 1 - 1e-6 < rep.lower_bound <= 1 + 1e-12
    assert len(rep.cell_edges[0]) == 4 and rep.cell_edges[0][0] == pytest.approx(0) and \
        rep.cell_edges[0][-1] == pytest.approx(2)


def test_affine_map_has_constant_det():
    lat = vpffd.Lattice([-1, 0, 0], [1, 2, 1], shape=(6, 5, 7), degree=(3, 2, 3))
    A = np.array([[1.2, 0.3, -0.4], [0.1, 0.8, 0.2], [-0.3, 0.5, 1.5]])
    P = lat.rest_points @ A.T + [4, -1, 2]
    rep = vpffd.check_folds(lat, P)
    det = np.linalg.det(A)
    assert rep.certified
    assert rep.min_det == pytest.approx(det, rel=1e-12)
    assert det * (1 - 1e-6) < rep.lower_bound <= det * (1 + 1e-12)  # the rounding bound, as above
    assert np.allclose(rep.cell_min_det, det, rtol=1e-12)


def test_twist_90_is_certified():
    lat = vpffd.Lattice([-1, -1, -1], [1, 1, 1], shape=8, degree=3)
    rep = vpffd.check_folds(lat, vpffd.twist(lat.rest_points, 90))
    assert rep.certified, rep
    assert 0 < rep.lower_bound <= rep.min_det
    dets = fd_det(lat, vpffd.twist(lat.rest_points, 90), grid_points(lat, 7))
    assert dets.min() >= rep.lower_bound * (1 - 1e-6)


@pytest.mark.parametrize("degree", [1, 2, 3])
def test_swapped_slabs_fold_with_a_verified_witness(degree):
    lat = vpffd.Lattice([0, 0, 0], [1, 1, 1], shape=7, degree=degree)
    P = swapped_slabs(lat)
    rep = vpffd.check_folds(lat, P)
    assert rep.folded and not rep.certified
    assert rep.witness.shape == (3,) and rep.witness_det < 0
    assert fd_det(lat, P, rep.witness)[0] < 0
    assert fd_det(lat, P, rep.witness)[0] == pytest.approx(rep.witness_det, rel=1e-5)
    i, j, k = rep.witness_cell
    assert rep.status[i, j, k] == folds.FOLDED
    assert (rep.cell_of(rep.witness[None]) == rep.witness_cell).all()
    assert "FOLDS" in rep.verdict() and f"cell ({i}, {j}, {k})" in rep.verdict()


@pytest.mark.parametrize("amplitude", [0.005, 0.05, 0.15, 0.3, 0.6, 1.2])
def test_random_edits_agree_with_dense_sampling(amplitude):
    rng = np.random.default_rng(int(amplitude * 1000))
    for trial in range(3):
        degree = (3, 2, 1)[trial]
        lat = vpffd.Lattice([0, 0, 0], [1, 1, 1], shape=degree + 4, degree=degree)
        P = lat.rest_points + rng.normal(0, amplitude / (degree + 3), lat.rest_points.shape)
        rep = vpffd.check_folds(lat, P)
        assert not (rep.certified and rep.folded)
        X = grid_points(lat, 12)
        dets = fd_det(lat, P, X)
        if dets.min() < -1e-6:
            assert not rep.certified
            # spec (e): every sampled point with det J < 0 lies in a folded or unknown cell
            assert (rep.status_at(X[dets < -1e-6]) != folds.CERTIFIED).all()
        if rep.certified:
            assert dets.min() > 0 and rep.lower_bound <= dets.min() * (1 + 1e-6)
        if rep.folded:
            assert fd_det(lat, P, rep.witness)[0] < 0
        assert rep.lower_bound <= rep.min_det


def test_degenerate_lattice_is_never_certified():
    """All control points on a plane: det J = 0 identically; rounding makes some
    coefficients positive, which must not certify a cell."""
    lat = vpffd.Lattice([0, 0, 0], [1, 1, 1], shape=6, degree=3)
    n = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    P = lat.rest_points - (lat.rest_points @ n)[..., None] * n
    rep = vpffd.check_folds(lat, P, depth=5)
    assert not rep.certified and not rep.folded
    assert (rep.status == folds.UNKNOWN).all()
    assert "undecided" in rep.verdict()


def test_thread_count_does_not_change_the_report():
    lat = vpffd.Lattice([0, 0, 0], [1, 1, 1], shape=9, degree=3)
    P = lat.rest_points + np.random.default_rng(5).normal(0, 0.05, lat.rest_points.shape)
    a, b = vpffd.check_folds(lat, P, threads=1), vpffd.check_folds(lat, P, threads=3)
    assert (a.status == b.status).all() and (a.cell_min_det == b.cell_min_det).all()
    assert a.certified == b.certified and a.folded == b.folded


# --- the paper's scenes ----------------------------------------------------------
def test_paper_twisting_cube_to_345_degrees():
    """The demo's twisting cube (5x5x5 cubic lattice, box(12)): the frames are
    checked with and without the volume correction. Whatever the verdict, it
    must agree with sampling; the twist of the plain FFD stays fold-free up to
    345 deg because consecutive control layers turn by at most 86 deg."""
    cube = vpffd.shapes.box(12)
    lat = vpffd.Lattice.around(cube, shape=(5, 5, 5), degree=3, padding=0.02)
    d = vpffd.Deformer(cube, lat, backend="serial")
    anim = Twist(lat, angle=345, axis="z", duration=1.0)
    for t in (0.25, 0.5, 0.75, 1.0):
        P = anim(t)
        for Q in (P, d.deform(P).control_points):
            rep = vpffd.check_folds(lat, Q)
            dets = fd_det(lat, Q, grid_points(lat, 10))
            if rep.certified:
                assert dets.min() > 0
            if rep.folded:
                assert fd_det(lat, Q, rep.witness)[0] < 0
            if dets.min() < -1e-6:
                assert not rep.certified
    rep = d.check_folds(anim(1.0))
    assert rep.certified, rep  # the plain twist to 345 deg does not fold
    assert rep.vertex_min_det > 0


def test_paper_ball_squash():
    """The demo's bouncing ball at its deepest flattening (squash 0.7): the plain
    FFD is proven fold-free, but the exact volume correction folds the lattice
    (the volume pushed back into a 70 % flattened ball turns cells inside out
    near the ground); the vertex Jacobians, computed independently, agree."""
    ball = vpffd.shapes.icosphere(3)
    lat = vpffd.Lattice.around(ball, shape=(8, 8, 8), degree=3, padding=0.05)
    anim = BouncingBall(lat, bottom=float(ball.bounds[0, 2]), squash=0.7, drop=0.5)
    d = vpffd.Deformer(ball, lat, backend="serial")
    worst = max(anim.times(41), key=anim.flattening)  # the deepest flattening
    plain = d.check_folds(anim(worst))
    assert plain.certified and plain.vertex_min_det > 0
    with pytest.raises(vpffd.FoldError) as e:
        d.deform(anim(worst), on_fold="raise")
    rep = e.value.report
    assert rep.folded and rep.vertex_min_det < 0
    r = d.deform(anim(worst))
    assert fd_det(lat, r.control_points, rep.witness)[0] < 0


# --- Deformer.check_folds and deform(on_fold=...) -------------------------------------
@pytest.fixture(scope="module")
def cube_case():
    cube = vpffd.shapes.box(8)
    lat = vpffd.Lattice.around(cube, shape=(7, 7, 7), degree=3, padding=0.05)
    return cube, lat


def test_deformer_check_folds_adds_vertex_det(cube_case):
    cube, lat = cube_case
    d = vpffd.Deformer(cube, lat, backend="serial")
    P = swapped_slabs(lat)
    rep = d.check_folds(P)
    J = d.jacobians(P)
    det = np.linalg.det(J)
    # The core expands det J by cofactors, numpy factors J: the two differ by rounding,
    # a few eps times the Hadamard bound prod |row| (1e-13 of it is far above that).
    bound = 1e-13 * np.prod(np.linalg.norm(J, axis=1), axis=1)
    assert abs(rep.vertex_min_det - det.min()) <= bound.max()
    assert abs(det[rep.vertex_argmin] - det.min()) <= 2 * bound.max()
    assert rep.folded
    # spec (e): vertices with det J < 0 lie in folded or unknown cells
    assert (rep.status_at(cube.vertices[det < -1e-9]) != folds.CERTIFIED).all()
    det_v, status_v = folds.vertex_folds(d, P, rep)
    assert det_v.shape == (cube.n_vertices,) and status_v.shape == (cube.n_vertices,)
    assert (np.abs(det_v - det) <= bound).all()
    assert "vertex_min_det" in repr(rep) and "FOLDS" in rep.verdict()
    ok = d.check_folds()
    assert ok.certified and ok.vertex_min_det == pytest.approx(1.0, abs=1e-9)


def test_on_fold_modes(cube_case):
    cube, lat = cube_case
    d = vpffd.Deformer(cube, lat, backend="serial")
    good = d.deform(vpffd.squash(lat.rest_points, 0.8), on_fold="raise")
    assert good.folds is not None and good.folds.certified
    assert d.deform(vpffd.squash(lat.rest_points, 0.8)).folds is None  # "ignore" checks nothing
    before = good.vertices.copy()
    bad = swapped_slabs(lat)
    with pytest.raises(vpffd.FoldError, match=r"cell \(\d+, \d+, \d+\)") as e:
        d.deform(bad, on_fold="raise")
    assert e.value.report.folded
    assert np.array_equal(good.vertices, before)
    with pytest.warns(vpffd.FoldWarning, match=r"folds in cell \(\d+, \d+, \d+\)"):
        r = d.deform(bad, on_fold="warn")
    assert r.folds.folded and fd_det(lat, r.control_points, r.folds.witness)[0] < 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = d.deform(bad, on_fold="ignore")
    assert r.folds is None
    with pytest.raises(vpffd.InvalidInputError, match="on_fold"):
        d.deform(bad, on_fold="stop")


@pytest.mark.skipif(not getattr(vpffd._core, "has_vulkan", False) or
                    not any(x["suitable"] for x in vpffd.vulkan_devices()), reason="no Vulkan device")
def test_on_fold_raise_keeps_the_device_frame(cube_case):
    cube, lat = cube_case
    dev = [x for x in vpffd.vulkan_devices() if x["suitable"]][0]
    d = vpffd.Deformer(cube, lat, backend="vulkan", device=dev["index"])
    good = d.deform(vpffd.squash(lat.rest_points, 0.8), on_fold="raise")
    on_device = d._vk.vertices()
    with pytest.raises(vpffd.FoldError):
        d.deform(swapped_slabs(lat), on_fold="raise")
    assert np.array_equal(d._vk.vertices(), on_device)
    assert np.allclose(on_device, good.vertices, atol=1e-5)


@pytest.mark.skipif(not getattr(vpffd._core, "has_vulkan", False) or
                    not any(x["suitable"] for x in vpffd.vulkan_devices()), reason="no Vulkan device")
def test_on_fold_raise_on_the_first_frame_leaves_the_rest_shape(cube_case):
    cube, lat = cube_case
    dev = [x for x in vpffd.vulkan_devices() if x["suitable"]][0]
    d = vpffd.Deformer(cube, lat, backend="vulkan", device=dev["index"])
    with pytest.raises(vpffd.FoldError):
        d.deform(swapped_slabs(lat), on_fold="raise")
    # The device's plain FFD of the rest lattice, within the float32 bound derived in
    # tests/python/gpu_bounds.py: u (basis error + terms + 3) max|P - o|.
    from gpu_bounds import U32, _basis_error, _terms
    o = 0.5 * (lat.box_min + lat.box_max)
    bound = U32 * (_basis_error(lat) + _terms(lat) + 3) * np.abs(lat.rest_points - o).max()
    assert np.abs(d._vk.vertices() - cube.vertices).max() <= bound


# --- weights="auto" ----------------------------------------------------------------
def test_auto_weights_keep_the_correction_local():
    """A twist of the top half of a cube: with weights="auto" the control points of
    the untouched bottom half move at most 1 % of the top half's largest offset;
    uniform weights spread the correction over the whole lattice."""
    cube = vpffd.shapes.box(16)
    lat = vpffd.Lattice.around(cube, shape=(6, 6, 12), degree=3, padding=0.05)
    d = vpffd.Deformer(cube, lat, backend="serial")
    R = lat.rest_points
    z = R[..., 2]
    zmid = 0.5 * (z.min() + z.max())
    top = z > zmid
    # Twist only the top half, from 0 at the middle to 120 deg at the top.
    P = np.array(R)
    ang = np.radians(120) * np.clip((z - zmid) / (z.max() - zmid), 0, 1)
    c = lat.center
    x, y = R[..., 0] - c[0], R[..., 1] - c[1]
    P[..., 0] = c[0] + np.cos(ang) * x - np.sin(ang) * y
    P[..., 1] = c[1] + np.sin(ang) * x + np.cos(ang) * y
    uni = d.deform(P)
    auto = d.deform(P, weights="auto")
    for r in (uni, auto):
        assert r.volume_error < 1e-10
    def ratio(r):
        off = np.linalg.norm(r.offsets, axis=-1)
        return off[~top].max() / off[top].max()
    print(f"bottom/top offset ratio: uniform {ratio(uni):.3g}, auto {ratio(auto):.3g}")
    assert ratio(auto) <= 0.01
    assert ratio(uni) > 10 * ratio(auto)


def test_auto_weights_without_volume_change_are_uniform(cube_case):
    cube, lat = cube_case
    d = vpffd.Deformer(cube, lat, backend="serial")
    assert vpffd.local_weights.auto_weights(d, lat.rest_points) is None
    r = d.deform(lat.rest_points, weights="auto")
    assert np.abs(r.offsets).max() < 1e-12


# --- bad input -----------------------------------------------------------------------
def test_bad_input(cube_case):
    cube, lat = cube_case
    with pytest.raises(vpffd.InvalidInputError, match="expected shape"):
        vpffd.check_folds(lat, np.zeros((5, 5, 5, 3)))
    with pytest.raises(vpffd.InvalidInputError, match="rows"):
        vpffd.check_folds(lat, np.zeros((10, 3)))
    P = np.array(lat.rest_points)
    P[1, 2, 3, 0] = np.nan
    with pytest.raises(vpffd.InvalidInputError, match="NaN"):
        vpffd.check_folds(lat, P)
    for depth in (-1, folds.MAX_DEPTH + 1):
        with pytest.raises(vpffd.InvalidInputError, match="depth"):
            vpffd.check_folds(lat, depth=depth)
    with pytest.raises(TypeError, match="depth"):
        vpffd.check_folds(lat, depth=2.5)
    with pytest.raises(TypeError, match="Lattice"):
        vpffd.check_folds(np.zeros((4, 4, 4, 3)))
    with pytest.raises(vpffd.InvalidInputError, match="threads"):
        vpffd.check_folds(lat, threads=0)
    d = vpffd.Deformer(cube, lat, backend="serial")
    with pytest.raises(vpffd.InvalidInputError, match="weights"):
        d.deform(weights="local")
    with pytest.raises(TypeError):
        bool(vpffd.check_folds(lat))
    # the caller's array is not modified
    Q = np.array(lat.rest_points)
    Q0 = Q.copy()
    vpffd.check_folds(lat, Q)
    assert np.array_equal(Q, Q0)


# --- the command line and the demo print a verdict -----------------------------------
@pytest.mark.skipif(not vpffd._core.has_openmesh, reason="deform writes a mesh file (OpenMesh)")
def test_cli_deform_and_demo_print_fold_verdicts(tmp_path, capsys):
    from vpffd.cli.main import main
    from vpffd.cli.demo import run_demo
    vpffd.save_mesh(tmp_path / "s.obj", vpffd.shapes.icosphere(2))
    assert main(["deform", str(tmp_path / "s.obj"), str(tmp_path / "o.obj"), "--squash", "0.3",
                 "--twist", "200"]) == 0
    out = capsys.readouterr().out
    assert "folds: FOLDS in the mesh" in out and "det J = -" in out and "cell (" in out
    assert main(["deform", str(tmp_path / "s.obj"), str(tmp_path / "o.obj"), "--twist", "45"]) == 0
    assert "folds: fold-free" in capsys.readouterr().out
    import io
    s = io.StringIO()
    res = run_demo(out=tmp_path / "demo", quick=True, render=False, stream=s, motion=False)
    text = s.getvalue()
    assert "folds (plain, " in text
    # one verdict word per variant on every frame line
    frames = sum(sc.frames for sc in res["scenes"])
    lines = [ln for ln in text.splitlines() if ln.rstrip().endswith(("ok", "FOLD", "?", "*"))
             and ln.strip()[:1].isdigit()]
    assert len(lines) == frames


@pytest.mark.skipif(not vpffd._core.has_embree, reason="no Embree in this build")
def test_render_marks_the_vertices_in_folded_cells(cube_case):
    from vpffd.colormap import FOLD_COLOR
    mesh, lat = cube_case[0], cube_case[1]
    bad = swapped_slabs(lat)
    d = vpffd.Deformer(mesh, lat)
    rep = vpffd.check_folds(lat, bad)
    assert rep.folded
    X = d.ffd(bad)
    cam = vpffd.Camera.framing(X, size=(160, 120))
    assert FOLD_COLOR[1] > FOLD_COLOR[0] + 0.4 and FOLD_COLOR[1] > FOLD_COLOR[2] + 0.4  # green

    def fold_pixels(img):
        # Shading scales the colour; its hue stays: green well above red and blue.
        r, g, b = (img[..., c].astype(int) for c in range(3))
        return int(((g > r + 40) & (g > b + 40)).sum())

    plain = vpffd.render((X, mesh.faces), camera=cam, size=(160, 120))
    marked = vpffd.render((X, mesh.faces), camera=cam, size=(160, 120), folds=rep, rest_vertices=mesh.vertices)
    status = rep.status_at(mesh.vertices)
    assert (status == folds.FOLDED).any()
    assert fold_pixels(plain) == 0 and fold_pixels(marked) > 50
    # The per-vertex status array gives the same picture.
    same = vpffd.render((X, mesh.faces), camera=cam, size=(160, 120), folds=status)
    assert np.array_equal(same, marked)
    with pytest.raises(vpffd.InvalidInputError, match="rest_vertices"):
        vpffd.render((X, mesh.faces), camera=cam, size=(160, 120), folds=rep)
