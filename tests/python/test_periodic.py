"""Periodic lattices: construction, the wrap of rest points, seam continuity, the
volume correction on the distinct control points, and what refuses them (the Vulkan
backend: test_vulkan_periodic.py)."""
import numpy as np
import pytest

import vpffd
from vpffd import InvalidInputError
from vpffd.animate import PathOffset
from vpffd.normals import angles_deg

BOX_MIN = np.array([-1.0, -0.5, -0.4])
BOX_MAX = np.array([2.0, 0.5, 0.4])
EXT = BOX_MAX - BOX_MIN
DIAG = float(np.linalg.norm(EXT))


def _lattice(seam="closed", shape=(7, 4, 4), degree=3, periodic="x"):
    return vpffd.Lattice(BOX_MIN, BOX_MAX, shape=shape, degree=degree, periodic=periodic, seam=seam)


def _random_points(n, rng, lo=BOX_MIN, hi=BOX_MAX):
    return lo + rng.random((n, 3)) * (hi - lo)


def _perturbed(lat, rng, amount=0.05):
    return lat.rest_points + amount * DIAG * rng.standard_normal(lat.rest_points.shape)


def _mirror_yz(X):
    Y = np.array(X, dtype=np.float64)
    Y[:, 1:] = (BOX_MIN + BOX_MAX)[1:] - Y[:, 1:]
    return Y


# --- construction -------------------------------------------------------------------
@pytest.mark.parametrize("periodic, words", [
    ("w", "axis 'w'"), ("xx", "twice"), ("xw", "axis 'w'"), (0, "string"), (["x", 1], "string"), (1.5, "string"),
])
def test_bad_periodic_axis_names(periodic, words):
    with pytest.raises(InvalidInputError, match=words):
        vpffd.Lattice(BOX_MIN, BOX_MAX, shape=6, periodic=periodic)


def test_too_few_distinct_points_for_the_degree():
    with pytest.raises(InvalidInputError, match="3 distinct control points along periodic axis x are too few for degree 3.*at least degree"):
        vpffd.Lattice(BOX_MIN, BOX_MAX, shape=(3, 5, 5), degree=3, periodic="x")
    vpffd.Lattice(BOX_MIN, BOX_MAX, shape=(4, 5, 5), degree=3, periodic="x")  # degree + 1 is enough


def test_knots_with_periodic_are_refused():
    knots = [vpffd._core.clamped_uniform_knots(6, 3)] * 3
    with pytest.raises(InvalidInputError, match="knots cannot be given with periodic"):
        vpffd.Lattice(BOX_MIN, BOX_MAX, knots=knots, periodic="x")


def test_bad_seams():
    with pytest.raises(InvalidInputError, match="seam along x must be one of"):
        _lattice(seam="round")
    with pytest.raises(InvalidInputError, match="not periodic"):
        _lattice(seam={"y": "closed"})
    with pytest.raises(InvalidInputError, match="cannot be periodic too"):
        _lattice(seam={"x": "twist", "y": "closed"}, periodic="xy")
    lat = _lattice(seam={"x": "closed", "y": "shift"}, periodic="xy")
    assert lat.seams == {"x": "closed", "y": "shift"} and lat.periodic == "xy"


def test_shape_counts_distinct_points():
    lat = _lattice(shape=(7, 4, 5), degree=(3, 2, 2), periodic="xz", seam="shift")
    assert lat.shape == (7, 4, 5)
    assert lat.extended_shape == (10, 4, 7)
    assert lat.control_points.shape == (7, 4, 5, 3)
    assert lat.expanded_control_points().shape == (10, 4, 7, 3)


# --- the wrap -----------------------------------------------------------------------
# A point and its copy k extents away are evaluated at the same wrapped parameter; the
# wrap itself rounds by one ulp of the coordinate (~5e-16 * 3 here) and the FFD sums
# 64 products of control points of size ~3: both far below 1e-12 of the diagonal.
TOL = 1e-12 * DIAG


def test_closed_seam_maps_a_point_and_its_translate_to_the_same_place():
    rng = np.random.default_rng(1)
    lat = _lattice("closed")
    P = _perturbed(lat, rng)
    X = _random_points(300, rng)
    D = lat.deform_points(X, P)
    for k in (1, -1, 3):
        Xk = X + k * EXT[0] * np.array([1.0, 0, 0])
        assert np.abs(lat.deform_points(Xk, P) - D).max() <= TOL


def test_shift_seam_tiles_space():
    rng = np.random.default_rng(2)
    lat = _lattice("shift")
    X = _random_points(300, rng)
    # The rest lattice is the identity everywhere along the periodic axis.
    far = X + np.array([[7 * EXT[0], 0, 0]])
    assert np.abs(lat.deform_points(far) - far).max() <= 8 * TOL
    # An edit repeats with the period: D(x + L) = D(x) + L.
    P = _perturbed(lat, rng)
    e = np.array([EXT[0], 0, 0])
    assert np.abs(lat.deform_points(X + e, P) - (lat.deform_points(X, P) + e)).max() <= 2 * TOL


def test_twist_seam_comes_back_mirrored():
    rng = np.random.default_rng(3)
    lat = _lattice("twist")
    P = _perturbed(lat, rng)
    X = _random_points(300, rng)
    e = np.array([EXT[0], 0, 0])
    D = lat.deform_points(X, P)
    assert np.abs(lat.deform_points(X + e, P) - lat.deform_points(_mirror_yz(X), P)).max() <= TOL
    assert np.abs(lat.deform_points(X + 2 * e, P) - D).max() <= 2 * TOL


def test_outside_never_fires_along_a_periodic_axis():
    lat = _lattice("closed")
    lat.deform_points([[50.0, 0.0, 0.0]])
    with pytest.raises(InvalidInputError, match="outside the lattice box"):
        lat.deform_points([[0.0, 5.0, 0.0]])


# --- continuity across the seam -----------------------------------------------------
def _seam_deformer(lat, half=1e-3):
    """A small closed box mesh centred on the seam (x = box_max): half its vertices
    lie beyond the box and are wrapped to its start."""
    m = vpffd.shapes.box(2, size=2 * half)
    V = m.vertices + np.array([BOX_MAX[0], 0.1, -0.05])
    return vpffd.Deformer(vpffd.Mesh(V, m.faces), lat, backend="serial")


@pytest.mark.parametrize("degree", [2, 3, 4])
def test_positions_and_jacobians_are_continuous_across_the_seam(degree):
    rng = np.random.default_rng(10 + degree)
    lat = _lattice("closed", shape=(8, 4, 4), degree=(degree, 2, 2))
    P = _perturbed(lat, rng, 0.1)
    y, z = 0.1, -0.05
    # One-sided limits at the seam: just below box_max and exactly at box_min (its twin).
    below = np.array([[BOX_MAX[0] * (1 - 1e-15), y, z]])
    at = np.array([[BOX_MIN[0], y, z]])
    assert np.abs(lat.deform_points(below, P) - lat.deform_points(at, P)).max() <= TOL
    # Jacobians at x_max - d and x_max + d (wrapped): a C^1 map differs by at most
    # max|dJ/dx| * 2d; |dJ/dx| <= (2 degree / h)^2 * max|P| ~ 1e3 here, d = 1e-3 * 2 / 2:
    # 1e-3 * 1e3 * 2 = 2 is no bound, so compare with d shrinking instead: the difference
    # must fall linearly with d (a jump in J would stay).
    diffs = []
    for half in (1e-3, 1e-4, 1e-5):
        d = _seam_deformer(lat, half)
        V = d.mesh.vertices
        J = d.jacobians(P)
        lo = np.where(np.isclose(V[:, 0], BOX_MAX[0] - half, rtol=0, atol=half * 1e-6))[0]
        hi = np.where(np.isclose(V[:, 0], BOX_MAX[0] + half, rtol=0, atol=half * 1e-6))[0]
        key = lambda idx: np.lexsort((V[idx, 2], V[idx, 1]))  # noqa: E731
        lo, hi = lo[key(lo)], hi[key(hi)]
        assert np.allclose(V[lo, 1:], V[hi, 1:])
        diffs.append(np.abs(J[lo] - J[hi]).max())
    assert diffs[1] <= 0.2 * diffs[0] and diffs[2] <= 0.2 * diffs[1], diffs


@pytest.mark.parametrize("degree", [3, 4])
def test_second_derivatives_are_continuous_across_the_seam(degree):
    """C^{d-1} with d >= 3: the difference quotient of J along x over a step h on each
    side of the seam tends to one value; their mismatch falls like h (a jump in the
    second derivative would leave it constant)."""
    rng = np.random.default_rng(20 + degree)
    lat = _lattice("closed", shape=(8, 4, 4), degree=(degree, 2, 2))
    P = _perturbed(lat, rng, 0.1)

    def fx(x):  # dD/dx by central differences of the map, step 1e-6 (error ~1e-12/1e-6)
        e = 1e-6
        pts = np.array([[x + e, 0.1, -0.05], [x - e, 0.1, -0.05]])
        D = lat.deform_points(pts, P)
        return (D[0] - D[1]) / (2 * e)

    mismatch = []
    for h in (1e-2, 5e-3, 2.5e-3):
        left = (fx(BOX_MAX[0] - 1e-4) - fx(BOX_MAX[0] - 1e-4 - h)) / h
        right = (fx(BOX_MIN[0] + 1e-4 + h) - fx(BOX_MIN[0] + 1e-4)) / h
        mismatch.append(np.abs(left - right).max())
    assert mismatch[1] <= 0.6 * mismatch[0] and mismatch[2] <= 0.6 * mismatch[1], mismatch


def test_normals_are_continuous_across_the_seam():
    rng = np.random.default_rng(4)
    lat = _lattice("closed")
    P = vpffd.edits.ring(lat, radius=1.0) + 1e-3 * rng.standard_normal(lat.shape + (3,))
    d = _seam_deformer(lat, 1e-4)
    N = vpffd.deformed_normals(d, P)
    # The same mesh one extent back lies inside the box: same surface, same normals.
    back = vpffd.Mesh(d.mesh.vertices - np.array([EXT[0], 0, 0]), d.mesh.faces)
    N2 = vpffd.deformed_normals(vpffd.Deformer(back, lat, backend="serial"), P)
    assert np.nanmax(angles_deg(N, N2)) < 1e-6


# --- the volume correction ----------------------------------------------------------
@pytest.mark.parametrize("seam", ["shift", "closed"])
def test_volume_is_exact_and_offsets_are_on_distinct_points(seam):
    lat = _lattice(seam, shape=(8, 5, 5))
    mesh = vpffd.shapes.icosphere(3, 0.3)
    # Straddling the seam: part of the mesh is wrapped to the box's start.
    mesh = vpffd.Mesh(mesh.vertices + np.array([BOX_MAX[0] - 0.1, 0, 0]), mesh.faces)
    d = vpffd.Deformer(mesh, lat)
    P = lat.rest_points.copy() if seam == "shift" else vpffd.edits.ring(lat, radius=1.0)
    # A periodic swelling along the band (the same at both ends of the box: no seam).
    wave = 1.0 + 0.3 * np.sin(2 * np.pi * (lat.rest_points[..., 0] - BOX_MIN[0]) / EXT[0])
    P[..., 2] = lat.center[2] + (P[..., 2] - lat.center[2]) * wave
    r = d.deform(P)
    # The correction moves the vertices by ~1e-2; the volume sum rounds at ~(F+4) u of
    # its size (F = 1280 faces): 1e-12 relative is far above that and far below any miss.
    assert abs(r.volume - d.rest_volume) <= 1e-12 * d.rest_volume
    assert r.control_points.shape == lat.shape + (3,) and r.offsets.shape == lat.shape + (3,)
    # The vertices are the plain FFD of the corrected distinct points (their copies tied).
    assert np.abs(d.ffd(r.control_points) - r.vertices).max() <= TOL
    assert r.volume_before != pytest.approx(d.rest_volume, rel=1e-6)


def test_weights_fixed_and_constraints_take_distinct_points():
    lat = _lattice("shift", shape=(8, 5, 5))
    mesh = vpffd.shapes.icosphere(3, 0.3)
    d = vpffd.Deformer(mesh, lat)
    P = lat.rest_points * np.array([1.0, 1.0, 0.8])
    fixed = np.zeros(lat.shape, bool)
    fixed[0] = True
    r = d.deform(P, fixed=fixed, constraints=[(0, mesh.vertices[0] + [0, 0, 0.01])])
    assert np.all(r.offsets[0] == 0)
    # The tied copies of slice 0 did not move either: the FFD of the result matches.
    assert np.abs(d.ffd(r.control_points) - r.vertices).max() <= TOL
    ra = d.deform(P, weights="auto")
    assert abs(ra.volume - d.rest_volume) <= 1e-12 * d.rest_volume
    assert r.constraint_error <= 1e-12
    assert abs(r.volume - d.rest_volume) <= 1e-12 * d.rest_volume
    with pytest.raises(InvalidInputError, match="outside the box along a periodic axis"):
        d.deform(P, constraints=[((BOX_MAX[0] + 0.5, 0, 0), (0, 0, 0))])


def test_folded_coefficients_predict_the_volume_change():
    """volume_coefficients of a periodic Deformer are over the distinct points:
    alpha . delta is the first-order volume change of moving them (copies included)."""
    lat = _lattice("closed", shape=(8, 5, 5))
    mesh = vpffd.Mesh(vpffd.shapes.icosphere(3, 0.3).vertices + np.array([BOX_MAX[0] - 0.1, 0, 0]),
                      vpffd.shapes.icosphere(3, 0.3).faces)
    d = vpffd.Deformer(mesh, lat)
    P = vpffd.edits.ring(lat, radius=1.0)
    X = d.ffd(P)
    alpha, vol = d.volume_coefficients(X, "x")
    assert alpha.shape == (lat.n_control_points,)
    delta = np.zeros(lat.shape + (3,))
    delta[0, 2, 2, 0] = 1e-4  # a point whose copy is in the extended lattice
    v2 = vpffd.Mesh(d.ffd(P + delta), mesh.faces).volume
    # The volume is linear in the x-coordinates of the control points (one axis moved).
    assert v2 - vol == pytest.approx(alpha @ delta[..., 0].ravel(), rel=1e-9)


def test_basis_matrices():
    rng = np.random.default_rng(6)
    lat = _lattice("closed")
    P = _perturbed(lat, rng)
    X = _random_points(50, rng)
    B = lat.basis_matrix(X)
    assert B.shape == (50, lat.n_control_points)
    assert np.abs(B @ P.reshape(-1, 3) - lat.deform_points(X, P)).max() <= TOL
    with pytest.raises(InvalidInputError, match="affine"):
        _lattice("shift").basis_matrix(X)


def test_fold_check_covers_the_seam():
    lat = _lattice("shift")
    assert vpffd.check_folds(lat).certified
    P = lat.rest_points.copy()
    P[0, :, :, 0] += 2.5 * EXT[0] / lat.shape[0]  # first slice past its neighbours: folds
    rep = vpffd.check_folds(lat, P)
    assert rep.folded


def test_multires_takes_periodic_lattices_on_the_cpu():
    # (test_multires_periodic.py checks the frames; the Vulkan refusal is tested there.)
    mr = vpffd.Multires(vpffd.shapes.bumpy_sphere(2, 0.3))
    lat = _lattice("closed")
    r = vpffd.MultiresDeformer(mr, lat, backend="serial").deform(lat.control_points, preserve_volume=False)
    diag = float(np.linalg.norm(np.ptp(mr.mesh.vertices, axis=0)))
    assert np.abs(r.vertices - mr.mesh.vertices).max() <= 1e-12 * diag


# --- moving rest positions ------------------------------------------------------------
def test_path_offset_wraps_by_the_period_of_the_map():
    rng = np.random.default_rng(7)
    X = _random_points(40, rng)
    for seam, period in (("closed", EXT[0]), ("twist", 2 * EXT[0]), ("shift", None)):
        lat = _lattice(seam)
        P = _perturbed(lat, rng)
        anim = PathOffset(lat, "x", speed=1.3)
        raw = PathOffset(lat, "x", speed=1.3, wrap=False)
        for t in (0.0, 2.0, 11.7, -5.0):
            o = anim.offset(t)
            if period is None:
                assert np.array_equal(o, raw.offset(t))
            else:
                assert 0 <= o[0] < period
            # Wrapping the offset changes no image.
            assert np.abs(lat.deform_points(anim.positions(X, t), P)
                          - lat.deform_points(raw.positions(X, t), P)).max() <= 40 * TOL
    X0 = X.copy()
    PathOffset(_lattice("closed"), (1, 1, 0), 2.0).positions(X, 3.0)
    assert np.array_equal(X, X0)


@pytest.mark.parametrize("kwargs, exc", [
    (dict(direction="w"), InvalidInputError), (dict(direction=(0, 0, 0)), InvalidInputError),
    (dict(direction=(1, 2)), InvalidInputError), (dict(speed=np.inf), InvalidInputError),
    (dict(speed="fast"), TypeError), (dict(wrap=1), TypeError),
])
def test_path_offset_bad_input(kwargs, exc):
    with pytest.raises(exc):
        PathOffset(_lattice("closed"), **kwargs)
