"""The optimised frame (one-pass coefficients from vertex rings, the volume and the
reordering fused into the last gather) against the frame written out plainly in
numpy/scipy from the paper's formulas; and what a frame no longer computes twice."""
import contextlib
import itertools

import numpy as np
import pytest

import vpffd

U = np.finfo(float).eps / 2  # unit roundoff


def _open_cap(mesh):
    """The mesh with the faces above z = 0.7 removed (an open surface)."""
    V, F = mesh.vertices, mesh.faces
    return vpffd.Mesh(V, F[(V[F][:, :, 2] < 0.7).any(axis=1)])


def plain_frame(d, P, axes, weights=None, fixed=None, constraints=(), rounds=1, closed=True):
    """The paper's frame in numpy: per step the weights from a face pass, alpha = B^T w
    with the explicit basis matrix, the volume by the signed-volume sum, the minimum-norm
    offsets of the volume row and the constraint rows, X += B delta along the axis.
    With parts (d built with parts=...), one volume row per part: part k's alpha is the
    scatter of its own vertices' weights, its share of what part k misses."""
    V, F = d.mesh.vertices, d.mesh.faces
    part = d.vertex_parts if d.n_parts > 1 else np.zeros(len(V), np.int32)
    K = int(part.max()) + 1
    face_part = part[F[:, 0]]
    o = np.asarray(d._d.origin)
    B = d.basis_matrix()
    N = B.shape[1]
    X = B @ P
    inv_w = np.ones(N) if weights is None else 1.0 / weights.reshape(-1)
    if fixed is not None:
        inv_w[fixed.reshape(-1)] = 0.0
    rows = [B[s].toarray()[0] if isinstance(s, int) else d.lattice.basis_matrix([s]).toarray()[0]
            for s, _ in constraints]

    def volumes(X):
        p = X[F] - o
        return np.bincount(face_part, np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])), K) / 6

    def volume(X):
        return volumes(X).sum()

    target = (d.rest_part_volumes if K > 1 else [d.rest_volume]) if closed else [d._d.rest_volume(True)]
    offsets = np.zeros((N, 3))
    before = volume(X)
    k = len(axes) * rounds
    for step in range(k):
        a = "xyz".index(axes[step % len(axes)])
        if closed:
            n = np.cross(X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]])[:, a]
            w = np.bincount(F.ravel(), np.repeat(n, 3), len(V)) / 6
        else:
            a1, a2 = (a + 1) % 3, (a + 2) % 3
            w = np.zeros(len(V))
            for c in range(3):
                pm, pn = X[F[:, (c + 1) % 3]] - o, X[F[:, (c + 2) % 3]] - o
                w += np.bincount(F[:, c], pm[:, a1] * pn[:, a2] - pm[:, a2] * pn[:, a1], len(V)) / 6
        alphas = [B.T @ np.where(part == j, w, 0.0) for j in range(K)]
        R = np.array(alphas + rows)
        b = np.array(list((target - volumes(X)) / (k - step)) +
                     [t[a] - r @ (P[:, a] + offsets[:, a]) for r, (_, t) in zip(rows, constraints)])
        RW = R * inv_w
        G = RW @ R.T
        delta = RW.T @ np.linalg.solve(G, b)
        delta += RW.T @ np.linalg.solve(G, b - R @ delta)  # one refinement step, as the library does
        offsets[:, a] += delta
        X[:, a] += B @ delta
    return X, offsets, volume(X), before, volumes(X)


def _variants(lat, P, X, axes):
    n, shape = lat.n_control_points, lat.shape
    yield "plain", {}
    yield "weights", dict(weights=np.linspace(0.3, 4.0, n).reshape(shape))
    fixed = np.zeros(n, bool)
    fixed[::3] = True
    yield "fixed", dict(fixed=fixed.reshape(shape))
    # A vertex and a rest-space point; the targets move only along the corrected axes.
    src = np.array([0.1, -0.2, 0.3])
    t_vertex, t_point = X[7].copy(), lat.deform_points([src], P)[0]
    for a in axes:
        t_vertex["xyz".index(a)] += 0.03
        t_point["xyz".index(a)] += 0.02
    yield "constraints", dict(constraints=[(7, t_vertex), (src, t_point)])
    yield "rounds", dict(rounds=3)


# Tolerance 1e-13 (of the box diagonal for vertices, of the largest offset for
# offsets; volumes: the bound derived in the loop): the two frames compute the same sums in
# different orders on a 642-vertex mesh, a few hundred roundings of 1.1e-16 at most;
# a pass on stale coordinates, a wrong corner or wrong weights errs by 1e-3 or more.
@pytest.mark.parametrize("closed", [True, False])
def test_optimised_frame_equals_plain_frame(closed):
    sphere = vpffd.shapes.icosphere(3)
    mesh = sphere if closed else _open_cap(sphere)
    lat = vpffd.Lattice.around(sphere, shape=(6, 5, 7), degree=3, padding=0.05)
    P = vpffd.edits.twist(vpffd.edits.squash(lat.control_points, 0.6), 70)
    diag = np.linalg.norm(lat.box_max - lat.box_min)
    n = lat.n_control_points
    subsets = ["".join(p) for r in (1, 2, 3) for p in itertools.permutations("xyz", r)]
    methods = ["traversal", "csr"] if closed else ["traversal"]
    for threads in (1, 2):
        d = vpffd.Deformer(mesh, lat, backend="openmp" if vpffd._core.has_openmp() else "serial", threads=threads)
        X0 = d.ffd(P)
        for axes, method in itertools.product(subsets, methods):
            for name, kw in _variants(lat, P, X0, axes):
                with pytest.warns(UserWarning) if not closed else contextlib.nullcontext():
                    r = d.deform(P, axes=axes, method=method, allow_open=not closed, **kw)
                X, offsets, vol, before, _ = plain_frame(d, P.reshape(-1, 3), axes, closed=closed, **kw)
                where = f"{axes} {name} {method} threads={threads}"
                assert np.abs(r.vertices - X).max() <= 1e-13 * diag, where
                assert np.abs(r.offsets.reshape(-1, 3) - offsets).max() <= 1e-13 * np.abs(offsets).max(), where
                # A volume is a sum of F face terms of ~4 roundings each, summed in a fixed
                # chunk order: within (F + 4) u sum|V_f| of the truth (sum|V_f| = |V| for a
                # star-shaped mesh around the lattice centre). Two such sums differ by twice that.
                vol_bound = (len(mesh.faces) + 4) * 2.0 ** -53 * abs(vol)
                assert abs(r.volume - vol) <= 2 * vol_bound, where
                assert abs(r.volume_before - before) <= 2 * vol_bound, where
                assert abs(r.volume - r.target_volume) <= vol_bound, where


def _volume_error(d, X):
    """How far two of the frame's volume measurements of a mesh near X may differ
    (derived at test_traversal_frame_equals_csr_frame): 4 (F + 64) u max(T, S)."""
    o = np.asarray(d._d.origin)
    p = X[d.mesh.faces] - o
    S = np.abs(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2]))).sum() / 6
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    T = max((np.abs(n[:, a])[:, None] * np.abs(p[:, :, a])).sum() / 6 for a in range(3))
    return 4 * (len(d.mesh.faces) + 64) * U * max(T, S)


def _two_spheres():
    s = vpffd.shapes.icosphere(3)
    mesh = vpffd.Mesh(np.concatenate([s.vertices, 0.8 * s.vertices + [2.2, 0.3, 0]]),
                      np.concatenate([s.faces, s.faces + s.n_vertices]))
    return mesh, np.repeat([0, 1], s.n_vertices)


# As above with two parts, each keeping its own volume (one volume row each): every axis
# order, weights, fixed points, constraints and rounds; and on a periodic lattice, where
# the basis matrix is over the distinct control points (its tied copies folded in) and
# so is the reference's solve. The spheres are off the lattice centre, so the volume
# sums' terms are of both signs: the volumes' tolerance and what it does to the offsets
# are derived from the terms' magnitudes and the steps' shares (_volume_error, as for
# the CSR comparison below).
@pytest.mark.parametrize("periodic", [False, True])
def test_optimised_parts_frame_equals_plain_frame(periodic):
    mesh, labels = _two_spheres()
    if periodic:
        lo, hi = mesh.vertices.min(axis=0) - 0.1, mesh.vertices.max(axis=0) + 0.1
        lat = vpffd.Lattice(lo, hi, shape=(9, 5, 6), degree=3, periodic="x", seam="closed")
    else:
        lat = vpffd.Lattice.around(mesh, shape=(9, 5, 6), degree=3, padding=0.05)
    P = vpffd.edits.twist(vpffd.edits.squash(lat.control_points, 0.6), 70)
    diag = np.linalg.norm(lat.box_max - lat.box_min)
    subsets = ["".join(p) for r in (1, 2, 3) for p in itertools.permutations("xyz", r)]
    for threads in (1, 2):
        d = vpffd.Deformer(mesh, lat, parts=labels,
                           backend="openmp" if vpffd._core.has_openmp() else "serial", threads=threads)
        assert d.n_parts == 2
        X0 = d.ffd(P)
        vol_err = _volume_error(d, X0)
        for axes in subsets:
            for name, kw in _variants(lat, P, X0, axes):
                r = d.deform(P, axes=axes, **kw)
                X, offsets, vol, before, parts = plain_frame(d, P.reshape(-1, 3), axes, **kw)
                where = f"{axes} {name} threads={threads}"
                share = min(abs(st["share"]) for st in r.steps)
                rel = 1e-13 + len(r.steps) * vol_err / share
                big = np.abs(offsets).max()
                assert rel < 1e-6, where  # meaningful: a wrong volume moves the offsets by O(1)
                assert np.abs(r.vertices - X).max() <= 1e-13 * diag + rel * big, where
                assert np.abs(r.offsets.reshape(-1, 3) - offsets).max() <= rel * big, where
                assert np.abs(r.part_volumes - parts).max() <= vol_err, where
                assert abs(r.volume_before - before) <= vol_err, where
                assert np.abs(r.part_volumes - r.part_target_volumes).max() <= vol_err, where


def test_frame_timings_only_when_asked():
    mesh = vpffd.shapes.icosphere(3)
    lat = vpffd.Lattice.around(mesh, shape=(5, 5, 5))
    d = vpffd.Deformer(mesh, lat, backend="serial")
    P = vpffd.edits.squash(lat.control_points, 0.5).reshape(-1, 3)
    assert "timings" not in d._d.deform(P)
    t = d._d.deform(P, vpffd._core.CorrectionOptions(record_timings=True))["timings"]
    parts = ["plan_ms", "ffd_ms", "coefficients_ms", "solves_ms", "gathers_ms", "volume_ms", "reorder_ms"]
    assert all(t[k] >= 0 for k in parts)
    assert sum(t[k] for k in parts) <= t["total_ms"] * (1 + 1e-9)


def test_mesh_volume_checks_closedness_once(monkeypatch):
    mesh = vpffd.shapes.icosphere(3)
    v = mesh.volume
    calls = []
    monkeypatch.setattr(vpffd._core, "edge_report", lambda *a: calls.append(a))
    monkeypatch.setattr(vpffd._core, "require_closed", lambda *a: calls.append(a))
    assert mesh.volume == v
    assert calls == []  # the connectivity's report is kept: no edge sort per call
    monkeypatch.undo()
    with pytest.raises(vpffd.InvalidInputError, match="boundary edges"):
        _open_cap(mesh).volume


# Where the numpy frame cannot be the reference (a "shift" seam's map is affine: no
# basis matrix) the CSR method is: it takes none of the traversal's shortcuts (the
# first step's coordinate set by its gather, earlier steps' volumes from alpha), and a
# shift seam turns them off for the traversal too. A sphere across the periodic seam
# (its image torn in two there), and mixed degrees (the per-point kernels).
# Tolerance: each measured volume is a fixed-order sum of F face terms, or of vertex
# terms w_v (x_v - o)_a whose magnitudes add to at most T = max_a sum_f sum_corners
# |n_f,a| |x_c - o|_a / 6, each term with a few roundings, those through alpha with
# the scatter's too (tens of u: the basis values and the power-form moments); so two
# volumes differ by at most vol_err = 4 (F + 64) u max(T, sum_f |V_f|). A step's
# offsets are W^-1 alpha share / G: an error e in the volume a step starts from moves
# its offsets by e / |share| relatively, and each later step inherits it.
@pytest.mark.parametrize("seam", ["closed", "twist", "shift", "mixed degrees"])
def test_traversal_frame_equals_csr_frame(seam):
    rng = np.random.default_rng(7)
    sphere = vpffd.shapes.icosphere(3)
    if seam == "mixed degrees":
        mesh = sphere
        lat = vpffd.Lattice.around(sphere, shape=(6, 5, 7), degree=(2, 3, 2), padding=0.05)
    else:
        mesh = vpffd.Mesh(0.4 * sphere.vertices + [0.95, 0.1, -0.1], sphere.faces)  # across x = 1
        lat = vpffd.Lattice((-1, -1, -1), (1, 1, 1), shape=(7, 4, 4), degree=3, periodic="x", seam=seam)
    P = lat.control_points + rng.normal(scale=0.04, size=lat.control_points.shape)
    d = vpffd.Deformer(mesh, lat, threads=2)
    vol_err = _volume_error(d, d.ffd(P))
    diag = np.linalg.norm(lat.box_max - lat.box_min)
    for axes in ("xyz", "zx", "yxz", "y"):
        a = d.deform(P, axes=axes)
        b = d.deform(P, axes=axes, method="csr")
        share = min(abs(s["share"]) for s in b.steps)
        rel = 1e-13 + len(axes) * vol_err / share
        big = np.abs(b.offsets).max()
        assert np.abs(a.offsets - b.offsets).max() <= rel * big, (seam, axes)
        assert np.abs(a.vertices - b.vertices).max() <= 1e-13 * diag + rel * big, (seam, axes)
        assert abs(a.volume_before - b.volume_before) <= vol_err, (seam, axes)
        assert abs(a.volume - a.target_volume) <= vol_err, (seam, axes)
        assert rel < 1e-6  # meaningful: a wrong first volume moves the offsets by O(1)
