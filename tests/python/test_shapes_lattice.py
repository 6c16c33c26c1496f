"""Lattice shapes (vpffd.edits.ring, mobius, terrain): closure at the seam, the
Moebius band's continuity and its straight limit, exact terrain following."""
import numpy as np
import pytest

import vpffd
from vpffd import InvalidInputError
from vpffd.normals import angles_deg

BOX_MIN = np.array([0.0, -0.5, -0.1])
BOX_MAX = np.array([6.0, 0.5, 0.1])


def _band(seam, shape=(16, 4, 3), degree=(3, 3, 2), lo=BOX_MIN, hi=BOX_MAX):
    return vpffd.Lattice(lo, hi, shape=shape, degree=degree, periodic="x", seam=seam)


# --- ring -------------------------------------------------------------------------------
def test_ring_closes_without_a_seam():
    lat = _band("closed")
    P = vpffd.edits.ring(lat)
    E = lat.expanded_control_points(P)
    n, d = lat.shape[0], lat.degree[0]
    # The tied copies are the first slices themselves, and the formula puts them there too.
    assert np.array_equal(E[n:], E[:d])
    # The centre line is a closed curve: its image just before the end of the box is
    # its image at the start (1e-12 of the ring's size: rounding of the wrap and the sums).
    y, z = 0.0, 0.0
    a = lat.deform_points([[BOX_MAX[0] * (1 - 1e-15), y, z]], P)
    b = lat.deform_points([[BOX_MIN[0], y, z]], P)
    assert np.linalg.norm(a - b) <= 1e-12 * 6
    # ... and goes once around the centre: the angle turns by 2 pi in total.
    X = np.stack([np.linspace(BOX_MIN[0], BOX_MAX[0], 400), np.zeros(400), np.zeros(400)], axis=1)
    D = lat.deform_points(X, P) - lat.center
    ang = np.unwrap(np.arctan2(D[:, 1], D[:, 0]))
    assert abs(abs(ang[-1] - ang[0]) - 2 * np.pi) < 2 * np.pi / 399 * 1.01
    # It does not fold (certified by Bernstein bounds on the extended net, seam included).
    assert not vpffd.check_folds(lat, P).folded


def test_ring_keeps_the_orientation_so_volumes_stay_positive():
    lat = _band("closed", shape=(16, 5, 5), degree=3, lo=np.array([0, -0.6, -0.6]), hi=np.array([6, 0.6, 0.6]))
    mesh = vpffd.Mesh(vpffd.shapes.icosphere(3, 0.4).vertices + [3.0, 0, 0], vpffd.shapes.icosphere(3, 0.4).faces)
    d = vpffd.Deformer(mesh, lat)
    r = d.deform(vpffd.edits.ring(lat))
    assert r.volume_before > 0
    assert abs(r.volume - d.rest_volume) <= 1e-12 * d.rest_volume


def test_ring_input_errors():
    with pytest.raises(InvalidInputError, match="seam='closed'"):
        vpffd.edits.ring(_band("shift"))
    with pytest.raises(InvalidInputError, match="seam='closed'"):
        vpffd.edits.ring(vpffd.Lattice(BOX_MIN, BOX_MAX, shape=5))
    with pytest.raises(InvalidInputError, match="must differ"):
        vpffd.edits.ring(_band("closed"), axis="x", around="x")
    with pytest.raises(InvalidInputError, match="exceed half"):
        vpffd.edits.ring(_band("closed"), radius=0.3)
    with pytest.raises(TypeError):
        vpffd.edits.ring(np.zeros((4, 4, 4, 3)))


# --- Moebius band -------------------------------------------------------------------------
def _mirror(X):
    Y = np.array(X, dtype=np.float64)
    Y[:, 1:] = (BOX_MIN + BOX_MAX)[1:] - Y[:, 1:]
    return Y


def test_mobius_is_continuous_across_its_seam():
    lat = _band("twist")
    P = vpffd.edits.mobius(lat, radius=1.0)
    L = BOX_MAX[0] - BOX_MIN[0]
    rng = np.random.default_rng(1)
    YZ = BOX_MIN[1:] + rng.random((20, 2)) * (BOX_MAX - BOX_MIN)[1:]
    dist = []
    for eps in (1e-2, 1e-3, 1e-4):
        end = np.column_stack([np.full(20, BOX_MAX[0] - eps * L), YZ])
        # The vertex's twin across the seam: s = eps, the band upside down.
        twin = _mirror(np.column_stack([np.full(20, BOX_MIN[0] + eps * L), YZ]))
        twin[:, 0] = BOX_MIN[0] + eps * L
        dist.append(np.linalg.norm(lat.deform_points(end, P) - lat.deform_points(twin, P), axis=1).max())
    # Distance -> 0 linearly with eps (the map is Lipschitz across the seam).
    assert dist[1] <= 0.15 * dist[0] and dist[2] <= 0.15 * dist[1], dist
    # And the same point one lap further round is the mirrored one, exactly.
    end = np.column_stack([np.full(20, BOX_MAX[0] - 1e-3), YZ])
    fwd = end + [L, 0, 0]
    assert np.abs(lat.deform_points(fwd, P) - lat.deform_points(_mirror(end), P)).max() <= 1e-12 * 6


def test_mobius_normals_agree_across_its_seam():
    lat = _band("twist")
    P = vpffd.edits.mobius(lat, radius=1.0)
    h = 1e-3
    # A flat slab straddling the seam (x = box_max); its top face's inner vertices at
    # x = max - h and max + h (the latter wrapped and mirrored) share the rest normal +z.
    m = vpffd.shapes.box(4, size=1.0)
    V = m.vertices * [4 * h, 0.2, 0.02] + np.array([BOX_MAX[0], 0.1, 0.0])
    d = vpffd.Deformer(vpffd.Mesh(V, m.faces), lat)
    N = vpffd.deformed_normals(d, P)
    top = np.isclose(V[:, 2], 0.01) & (np.abs(V[:, 1] - 0.1) < 0.09)
    lo = np.where(top & np.isclose(V[:, 0], BOX_MAX[0] - h))[0]
    hi = np.where(top & np.isclose(V[:, 0], BOX_MAX[0] + h))[0]
    lo, hi = lo[np.argsort(V[lo, 1])], hi[np.argsort(V[hi, 1])]
    assert len(lo) == len(hi) == 3 and np.allclose(V[lo, 1], V[hi, 1])
    # 2e-3 apart on the band, the normal turns by at most the band's curvature times
    # that (~1e-2 rad here), far below 1 degree; a flipped normal would be 180.
    assert np.nanmax(angles_deg(N[lo], N[hi])) < 1.0
    # The deformed slab is not turned inside out across the seam.
    r = d.deform(P, preserve_volume=False)
    assert vpffd.Mesh(r.vertices, m.faces).volume > 0


def test_mobius_tends_to_a_rigid_map_as_the_radius_grows():
    """R -> infinity with W, H and the control point spacing fixed (the box's length
    2 pi R along the band): curvature 1/R and twist rate 1/(2R) vanish, so the map
    tends to a rigid motion of the box: |J^T J - I| falls like 1/R (the spacing's own
    chord error, (h/R)^2 / 6, falls faster)."""
    W, H, h = 1.0, 0.2, 0.5
    err = []
    for R in (5.0, 10.0, 20.0):
        L = 2 * np.pi * R
        n = int(round(L / h))
        lat = vpffd.Lattice([0, -W / 2, -H / 2], [L, W / 2, H / 2], shape=(n, 4, 3), degree=(3, 3, 2),
                            periodic="x", seam="twist")
        P = vpffd.edits.mobius(lat, radius=R, width=W, height=H)
        m = vpffd.shapes.box(4, size=0.15)
        V = m.vertices + np.array([L / 3, 0.1, 0.0])
        J = vpffd.Deformer(vpffd.Mesh(V, m.faces), lat).jacobians(P)
        # Off the centre line (y = 0.1) the band is stretched by (R +- 0.1 cos)/R: the 1/R term.
        JtJ = np.einsum("vri,vrj->vij", J, J)
        assert (np.linalg.det(J) > 0).all()
        err.append(np.abs(JtJ - np.eye(3)).max())
    assert err[1] <= 0.6 * err[0] and err[2] <= 0.6 * err[1], err
    assert err[2] < 0.1


def test_mobius_input_errors():
    with pytest.raises(InvalidInputError, match="seam='twist'"):
        vpffd.edits.mobius(_band("closed"), radius=1.0)
    with pytest.raises(InvalidInputError, match="exceed half the width"):
        vpffd.edits.mobius(_band("twist"), radius=0.4)
    with pytest.raises(InvalidInputError, match="positive"):
        vpffd.edits.mobius(_band("twist"), radius=-1.0)


# --- terrain ----------------------------------------------------------------------------
def test_terrain_follows_a_linear_height_field_exactly():
    """B-splines reproduce linear functions, so with h(x, y) = a x + b y + c the map is
    exactly (x, y, z + h(x, y)) (to rounding: ~1e-15 of the box)."""
    lat = vpffd.Lattice([0, 0, 0], [4, 3, 1], shape=(7, 6, 4))
    P = vpffd.edits.terrain(lat, lambda x, y: 0.3 * x - 0.2 * y + 0.1)
    X = np.random.default_rng(2).random((100, 3)) * [4, 3, 1]
    D = lat.deform_points(X, P)
    want = X + np.column_stack([np.zeros(100), np.zeros(100), 0.3 * X[:, 0] - 0.2 * X[:, 1] + 0.1])
    assert np.abs(D - want).max() <= 1e-13


def test_terrain_from_an_array_and_on_a_periodic_lattice():
    lat = vpffd.Lattice([0, 0, 0], [4, 3, 1], shape=(8, 6, 4), periodic="x")
    x = lat.rest_points[:, :, 0, 0]
    h = 0.2 * np.sin(2 * np.pi * x / 4)
    P = vpffd.edits.terrain(lat, h)
    assert np.array_equal(P, vpffd.edits.terrain(lat, lambda x, y: 0.2 * np.sin(2 * np.pi * x / 4)))
    # A periodic field on a "shift" lattice: a car driving on keeps following it.
    X = np.array([[1.0, 1.5, 0.5]])
    a = lat.deform_points(X, P)
    b = lat.deform_points(X + [4.0, 0, 0], P)
    assert np.abs(b - a - [4.0, 0, 0]).max() <= 1e-12 * 5


def test_terrain_input_errors():
    lat = vpffd.Lattice([0, 0, 0], [4, 3, 1], shape=(7, 6, 4))
    with pytest.raises(InvalidInputError, match=r"shape \(3, 3\); expected \(7, 6\)"):
        vpffd.edits.terrain(lat, np.zeros((3, 3)))
    with pytest.raises(InvalidInputError, match="NaN"):
        vpffd.edits.terrain(lat, lambda x, y: x * np.nan)
    with pytest.raises(InvalidInputError, match="callable"):
        vpffd.edits.terrain(lat, "hills")
