"""Error bounds of the Vulkan backend against the CPU's double-precision frame.

The tests compare the device with the CPU within these bounds, derived from the
device's arithmetic (cpp/src/vulkan/shaders), not from what one machine printed: any
driver that rounds each float32 operation correctly (with or without fused
multiply-adds, on any CPU or GPU) stays inside them.

The device's arithmetic, per vertex (u = 2^-24, float32's unit roundoff):
- positions y = x - o are float32 (o: the lattice box centre), in a power-of-two unit
  (exact scaling);
- the FFD sums K = order_u order_v order_w products B_c P_c: the control points are
  rounded (u |P|), the per-axis basis values come from float32 power forms evaluated by
  Horner in a float32 local parameter; a basis value of degree d then errs by at most
  (3d + 2) 2^d u (coefficients of a span's power form sum to at most 2^d in absolute
  value, clamped end spans included; Horner adds 2d roundings, the rounded parameter d
  more through the derivative); the three axes' basis errors add (partition of unity:
  sum_ijk |dBu_i| Bv_j Bw_k = sum_i |dBu_i|); the K-term sum adds (K + 3) u;
- each axis step's gather adds sum_c B_c delta_c to one coordinate, with the same basis
  errors and a final rounding of the coordinate.
So a coordinate of a corrected vertex errs by at most
    u (basis + K + 3) max|P - o| + steps u (basis + K + 3) max|delta| + steps u max|y|.
Volumes and coefficients are summed in float64 or float-float (at least 44 bits); these
sums add at most n 2^-44 of the sum of the absolute terms.

Periodic lattices (lattice/periodic.h): the device evaluates the extended lattice, whose
control points the host expands in double (a "shift" seam adds the box's extent) and
rounds once each: the FFD's bound above holds with max|P - o| over the extended points.
The offsets are the distinct points', copied to their tied ones (no rounding). The rest
positions are wrapped into the box on the device in reals (embed.comp): the wrapped
coordinate errs by at most 4 U_SUM (|y| + extent) (a subtraction of turns * extent,
both rounded), which moves the image by at most that times the map's Lipschitz
constant Lip <= sum_a 2 d_a R / h_a (the derivative's difference form: d_a times
differences of control points, each at most 2 R = 2 max|P - o|, over knot spans h_a in
world units) and, on a "shift" seam, the translation by as much. The translation
(device units, rounded once to float32: u |T|, |T| <= |y| + R since the image of the
wrapped point lies in the control points' hull) is then added in float32 (u |y|), so a
shift seam adds u (2 |y| + R) to every vertex.

A corrected volume: each step measures the volume of the positions the device holds,
so only the rounding of the last step's coordinate remains unmeasured; the volume is
linear in each coordinate (V = sum_v g_v y_v, g the cone-volume gradient), so
    |V_device - target| <= sum_v |g_v,a| E_v,a (a: the last corrected axis)
with E the bound above for one gather. An uncorrected volume carries every vertex's
error: |dV| <= sum_v sum_a |g_v,a| E_v,a with E for the whole frame.
"""
from math import perm

import numpy as np

U32 = 2.0 ** -24
U_SUM = 2.0 ** -44  # float-float; float64 sums are tighter


def _basis_error(lat) -> float:
    """Sum over the three axes of the largest total basis-value error, in units of u."""
    return float(sum((3 * d + 2) * 2 ** d * (d + 1) for d in lat.degree))


def _terms(lat) -> int:
    return int(np.prod([d + 1 for d in lat.degree]))


def volume_gradient(vertices, faces, origin):
    """d V / d y_v of the cone volume from origin: (#V, 3)."""
    Y = np.asarray(vertices, float) - origin
    F = np.asarray(faces)
    G = np.zeros_like(Y)
    for c in range(3):
        np.add.at(G, F[:, c], np.cross(Y[F[:, (c + 1) % 3]], Y[F[:, (c + 2) % 3]]) / 6.0)
    return G


def _periodic_error(lat, Pe, y_max) -> float:
    """What a periodic lattice adds to a vertex's bound (the derivation above): the
    wrap's rounding through the map, and the shift seam's translation."""
    if not lat.periodic:
        return 0.0
    o = 0.5 * (lat.box_min + lat.box_max)
    R = float(np.abs(Pe - o).max())
    ext = lat.box_max - lat.box_min
    lip = 0.0
    for a in range(3):
        t = np.asarray(lat.knots[a], float)
        d = lat.degree[a]
        widths = np.diff(t)
        h = widths[widths > 0].min() * ext[a] / (t[len(t) - d - 1] - t[d])
        lip += 2 * d * R / h
    shift = any(s == "shift" for s in lat.seams.values())
    wrap = 4 * U_SUM * (y_max + float(ext.max())) * (lip + (1.0 if shift else 0.0))
    return wrap + (U32 * (2 * y_max + R) if shift else 0.0)


class Bounds:
    """The bounds of one CPU frame `c` (a deform result) on `mesh` in lattice `lat`."""

    def __init__(self, mesh, lat, c, P):
        o = 0.5 * (lat.box_min + lat.box_max)
        per_op = _basis_error(lat) + _terms(lat) + 3
        # The extended control points (the distinct ones without periodic axes).
        P = lat.expanded_control_points(np.asarray(P, float).reshape(*lat.shape, 3)).reshape(-1, 3)
        offsets = np.asarray(c.offsets, float).reshape(-1, 3)
        Y = np.asarray(c.vertices, float) - o
        steps = max(len(c.steps), 1)
        # A step's own offsets (with rounds, one step's may exceed the frame's total).
        delta = max([s["max_offset"] for s in c.steps] + [np.abs(offsets).max(initial=0.0)])
        self.step_error = U32 * (per_op * delta + np.abs(Y).max())
        # The plain FFD (of the wrapped positions, with a shift seam's translation), then
        # every step's gather and rounding.
        self.vertex = (U32 * per_op * np.abs(P - o).max() + _periodic_error(lat, P, float(np.abs(Y).max()))
                       + steps * self.step_error)
        G = np.abs(volume_gradient(c.vertices, mesh.faces, o))
        n_terms = 3 * len(mesh.faces)
        sum_error = n_terms * U_SUM * float(np.abs(Y).max() * G.sum())
        self.corrected_volume = float(self.step_error * G.sum(axis=0).max()) + sum_error
        self.plain_volume = float(self.vertex * G.sum()) + sum_error
        # Each step's share is (target - measured volume) / steps left: the measured
        # volumes differ by at most plain_volume. The offsets are share alpha / |alpha|^2
        # (plus constraint rows): to first order their relative change is the share's
        # plus twice the coefficients' (alpha = B^T w, w products of two coordinates).
        shares = [abs(s["share"]) for s in c.steps if abs(s["share"]) > 0]
        # With parts a step's share is the sum of the parts' shares, and each part's own
        # share sets its rows' multiplier: the smallest one counts. The volume is linear
        # in each axis's coordinates, so every step meets its shares, and part k's share
        # is the same in every step: (target_k - volume_before_k) / steps. Each part's
        # measured volume errs by at most its own vertices' and faces' terms of
        # plain_volume, whose sum (the whole mesh's) bounds the summed share's error.
        targets = getattr(c, "part_target_volumes", None)
        if targets is not None and len(targets) > 1 and c.steps:
            missing = np.abs(np.asarray(targets) - np.asarray(c.part_volumes_before)) / len(c.steps)
            shares += [float(s) for s in missing if s > 0]
        self.share = self.plain_volume
        self.offset_rel = (self.plain_volume / min(shares) if shares else 0.0) + 4 * self.vertex / np.abs(Y).max()


def check_frame(g, c, mesh, lat, P=None, cpu=None):
    """Asserts that device result g agrees with CPU result c within the bounds; with
    the CPU deformer `cpu`, also that the device's offsets explain its vertices (the
    FFD in double of its corrected control points)."""
    if P is None:
        P = np.asarray(c.control_points) - np.asarray(c.offsets)
    b = Bounds(mesh, lat, c, P)
    dv = np.abs(g.vertices - c.vertices).max()
    assert dv <= b.vertex, (dv, b.vertex)
    if cpu is not None:
        de = np.abs(cpu.ffd(g.control_points) - g.vertices).max()
        assert de <= b.vertex, (de, b.vertex)
    for sg, sc in zip(g.steps, c.steps):
        assert sg["axis"] == sc["axis"]
        assert abs(sg["share"] - sc["share"]) <= b.share, (sg["share"], sc["share"], b.share)
        assert abs(sg["max_offset"] - sc["max_offset"]) <= b.offset_rel * sc["max_offset"] + b.vertex
        # alpha^T W^-1 alpha has the units of a length^4: past 1e77 (or under 1e-77) it
        # leaves double range, and only its finite, normal values can be compared.
        if np.isfinite(sc["sum_squares"]) and sc["sum_squares"] > 1e-290:
            assert abs(sg["sum_squares"] - sc["sum_squares"]) <= 2 * b.offset_rel * sc["sum_squares"]
    if np.isfinite(c.target_volume):
        # The CPU lands on the target to double rounding (its own tests: 1e-12 relative).
        cpu_miss = abs(c.volume - c.target_volume) + 1e-12 * abs(c.target_volume)
        assert abs(g.volume - g.target_volume) <= b.corrected_volume, (g.volume, g.target_volume, b.corrected_volume)
        assert abs(g.volume - c.volume) <= b.corrected_volume + cpu_miss, (g.volume, c.volume)
    elif np.isfinite(c.volume):
        assert abs(g.volume - c.volume) <= b.plain_volume, (g.volume, c.volume, b.plain_volume)
    return b


# --- normals (shaders/normals.comp) ----------------------------------------------------
#
# The device forms N = normalize(cof(J~) n0~) in float32, J~ the Jacobian of the frame's
# control points q (P - o and the offsets, each rounded to float32, then added: at most
# 2 u (|q - o| + |delta|) per point). The basis values B_r and derivatives
# B'_r = dB_r/dtau * dtau/dx of each axis are evaluated in reals (float64 or float-float,
# relative rounding at most U_SUM per operation) from real power-form coefficients at the
# device's float32 local parameter (|tau_f - tau| <= u tau), then rounded to float32. With
# the span's power form c_qr and, at the vertex, A0 = sum_r |B_r|, A1 = sum_r |dB_r/dtau|,
# A2 = sum_r |d2B_r/dtau2| and the magnitudes Mk = sum_r sum_q q!/(q-k)! |c_qr| tau^(q-k):
#   the K values err in all by at most    eB = u (A0 + tau (A1 + u M2)) + (2d + 3) U_SUM M0
#   the K derivatives by at most          eD = g [u (A1 + tau (A2 + u M3)) + (4d + 5) U_SUM M1]
# (g = dtau/dx of the span: the rounding to float32, the parameter's rounding through the
# next derivative, and the real Horner passes with their 2d (values) and 4d (derivatives)
# operations, the coefficients' and the scale's rounding). Column a of J is
# sum_c q_c dB_c/dx_a as nested float32 sums over the three axes (K_u + K_v + K_w terms,
# one product each); with R_v = max |q_c - o| over the vertex's K^3 control points and
# S_a = g A1 (the other axes' values sum to 1):
#   |E_a| <= R_v (eD_a + S_a (eB_b + eB_c)) + (K_u + K_v + K_w + 3) u R_v S_a
#            + 2 u (R_v + max |delta|) S_a,
# times 1.01 for the second-order terms (products of the errors above, < 1e-5 relative).
# Then cof(J + E) n0 - cof(J) n0 = sum_a n0_a (e_b x c_c + c_b x e_c + e_b x e_c)
# (a, b, c cyclic, c_a the CPU's columns), so
#   |dn| <= sum_a |n0_a| (e_b |c_c| + |c_b| e_c + e_b e_c + 7 u |c~_b| |c~_c|)
# (7 u: the rounded rest normal, two roundings per cross product component, the product
# with n0 and the two additions; c~ = |c| + e), and the angle between the device's and
# the CPU's normal is at most asin(|dn| / |cof(J) n0|), plus 2 u for the normalisation
# and 2^-40 for the CPU's own double arithmetic (its J errs by a few 1e-16 relative).
# Evaluated per vertex on the vertex's own span (both spans for a vertex on a knot).
#
# The rest normal n0 itself is the device's (shaders/rest_normals.comp): the sum over the
# vertex's faces of (x1 - x0) x (x2 - x0) in reals, divided by its largest component and
# rounded to float32 once (the u of n0 above). Before that rounding it errs from the
# exact sum n by the reals' arithmetic: the rest positions y = (x - o) / s are stored with
# relative error U_SUM, so each edge errs by 2 U_SUM max|x - o| (plus U_SUM |edge| for
# its subtraction); each cross product component, a_d b_e - a_e b_d with two products and
# a subtraction, by 3 U_SUM |a| |b| plus the edges' errors times the other edge; and the
# sum over the vertex's m faces adds m U_SUM sum_f |a_f| |b_f|. Per component:
#   |delta| <= sum_f [(m + 5) U_SUM |a_f| |b_f| + 2 U_SUM (2 X_f + |a_f| + |b_f|) (|a_f| + |b_f|)]
# (X_f = max |x - o| over the face's corners; s cancels), and as a vector sqrt(3) times
# that. Its direction then errs by rho = sqrt(3) |delta| / |n|, which adds
# rho sum_a |c~_b| |c~_c| to |dn| (n0 of unit length: each |delta_a| / |n| <= rho).

def _power_forms(knots, degree):
    """{span: C} with C[q, r] the power-form coefficient of tau^q of function r on each
    non-empty span, reconstructed by interpolating the double basis at d + 1 points."""
    from vpffd import _core
    t = np.asarray(knots, float)
    d, K = degree, degree + 1
    n = len(t) - d - 1
    tau = np.linspace(0.0, 1.0, K)
    V = np.vander(tau, K, increasing=True)  # V[p, q] = tau_p^q
    out = {}
    for s in range(d, n):
        h = t[s + 1] - t[s]
        if h <= 0:
            continue
        # Nudged inside the span so that tau = 1 is evaluated on this span's piece.
        u = t[s] + np.minimum(tau, 1.0 - 1e-15) * h
        B = np.asarray(_core.basis_functions(list(t), d, list(u)))[:, s - d:s + 1]
        out[s] = np.linalg.solve(V, B)
    return out


def _axis_errors(knots, degree, u, du_dx):
    """Per point (parameter u): (eB, eD, S, first control point) of one axis, the
    worst over the spans the point may lie in."""
    t = np.asarray(knots, float)
    d, K = degree, degree + 1
    n = len(t) - d - 1
    forms = _power_forms(t, d)
    eB = np.zeros(len(u))
    eD = np.zeros(len(u))
    S = np.zeros(len(u))
    first = np.zeros(len(u), int)
    eps = 1e-9 * (t[n] - t[d])
    for shift in (-eps, 0.0, eps):
        span = np.clip(np.searchsorted(t, u + shift, side="right") - 1, d, n - 1)
        for s in np.unique(span):
            i = np.nonzero(span == s)[0]
            C = forms[int(s)]
            h = t[s + 1] - t[s]
            tau = np.clip((u[i] - t[s]) / h, 0.0, 1.0)[:, None]
            g = du_dx / h
            # The k-th derivatives of the K functions at tau (rows: points), and the
            # magnitude sums Mk.
            der = [sum(perm(qq, k) * C[qq] * tau ** (qq - k) for qq in range(k, K)) for k in range(3)]
            mag = [sum(perm(qq, k) * np.abs(C[qq]).sum() * tau[:, 0] ** (qq - k) for qq in range(k, K))
                   for k in range(4)]
            A0, A1, A2 = (np.abs(x).sum(axis=1) if np.ndim(x) == 2 else np.zeros(len(i)) for x in der)
            tau = tau[:, 0]
            eB[i] = np.maximum(eB[i], U32 * (A0 + tau * (A1 + U32 * mag[2])) + (2 * d + 3) * U_SUM * mag[0])
            eD[i] = np.maximum(eD[i], g * (U32 * (A1 + tau * (A2 + U32 * mag[3])) + (4 * d + 5) * U_SUM * mag[1]))
            S[i] = np.maximum(S[i], g * A1)
            if shift == 0.0:
                first[i] = s - d
    return eB, eD, S, first


def _jacobian_errors(lat, points, control_points, dmax=0.0):
    """Per point (rest-space, (V, 3)): the bounds of the derivation above on the device's
    Jacobian columns, e (V, 3), the largest |q - o| over the point's control points, R
    (V,), and the three axes' total basis-value errors, eB (3, V). ``dmax``: the largest
    offset added to the control points on the device (its rounding adds to theirs)."""
    X = np.asarray(points, float)
    # A periodic lattice: the extended control points at the wrapped points (a twist
    # seam's mirror changes the signs of two columns of J and of n0's components, not
    # their sizes).
    Q = lat.expanded_control_points(np.asarray(control_points, float).reshape(*lat.shape, 3))
    if lat.periodic:
        X = np.asarray(lat._spec.wrap_points(X)[0], float)
    o = 0.5 * (lat.box_min + lat.box_max)
    Ks = [d + 1 for d in lat.degree]
    n_v = len(X)
    eB, eD, S, first = [], [], [], []
    for a in range(3):
        t = np.asarray(lat.knots[a], float)
        d = lat.degree[a]
        lo, hi = t[d], t[len(t) - d - 1]
        du_dx = (hi - lo) / (lat.box_max[a] - lat.box_min[a])
        r = _axis_errors(t, d, lo + (X[:, a] - lat.box_min[a]) * du_dx, du_dx)
        for lst, x in zip((eB, eD, S, first), r):
            lst.append(x)
    # One more control point each side: a vertex on a knot may sit in either span.
    R = np.zeros(n_v)
    idx = [lambda f, i, a=a: np.clip(f + i, 0, Q.shape[a] - 1) for a in range(3)]
    for i in range(-1, Ks[0] + 1):
        for j in range(-1, Ks[1] + 1):
            for k in range(-1, Ks[2] + 1):
                q = Q[idx[0](first[0], i), idx[1](first[1], j), idx[2](first[2], k)]
                R = np.maximum(R, np.linalg.norm(q - o, axis=1))
    terms = sum(Ks) + 3
    e = 1.01 * np.stack([R * (eD[a] + S[a] * (eB[(a + 1) % 3] + eB[(a + 2) % 3])) + terms * U32 * R * S[a]
                         + 2 * U32 * (R + dmax) * S[a] for a in range(3)], axis=1)
    return e, R, np.array(eB)


def rest_normal_errors(lat, rest_vertices, faces):
    """(V,) rho: the bound of the derivation above on the direction error of the device's
    rest normals (rest_normals.comp) before their float32 rounding, relative to |n|."""
    X = np.asarray(rest_vertices, float)
    F = np.asarray(faces, np.int64)
    o = 0.5 * (lat.box_min + lat.box_max)
    a = np.linalg.norm(X[F[:, 1]] - X[F[:, 0]], axis=1)
    b = np.linalg.norm(X[F[:, 2]] - X[F[:, 0]], axis=1)
    Xf = np.linalg.norm(X[F] - o, axis=2).max(axis=1)
    deg = np.bincount(F.ravel(), minlength=len(X))
    n = np.zeros((len(X), 3))
    cross = np.cross(X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]])
    for c in range(3):
        np.add.at(n, F[:, c], cross)
    delta = np.zeros(len(X))
    for c in range(3):
        v = F[:, c]
        np.add.at(delta, v, (deg[v] + 5) * U_SUM * a * b + 2 * U_SUM * (2 * Xf + a + b) * (a + b))
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.sqrt(3) * delta / np.linalg.norm(n, axis=1)
    return np.where(np.isfinite(rho), rho, np.inf)


def normal_angle_bound(lat, rest_vertices, faces, control_points, jacobians, rest_normals, offsets=None):
    """(V,) bound in degrees on the angle between the device's normals and
    deformed_normals_exact of the same control points (the derivation above), the rest
    normals computed on the device from ``rest_vertices`` and ``faces``.
    ``offsets``: the frame's offsets (their rounding adds to the control points')."""
    dmax = 0.0 if offsets is None else float(np.abs(np.asarray(offsets, float)).max(initial=0.0)) * np.sqrt(3)
    e, _, _ = _jacobian_errors(lat, rest_vertices, control_points, dmax)
    rho = rest_normal_errors(lat, rest_vertices, faces)
    n_v = len(e)
    J = np.asarray(jacobians, float).reshape(-1, 3, 3)
    cols = np.linalg.norm(J, axis=1)  # |c_a| per vertex, (V, 3)
    N0 = np.asarray(rest_normals, float)
    n0 = np.abs(N0)
    dn = np.zeros(n_v)
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        dn += n0[:, a] * (e[:, b] * cols[:, c] + cols[:, b] * e[:, c] + e[:, b] * e[:, c]
                          + 7 * U32 * (cols[:, b] + e[:, b]) * (cols[:, c] + e[:, c]))
        dn += rho * (cols[:, b] + e[:, b]) * (cols[:, c] + e[:, c])
    Jc = [J[:, :, a] for a in range(3)]
    n = (N0[:, :1] * np.cross(Jc[1], Jc[2]) + N0[:, 1:2] * np.cross(Jc[2], Jc[0])
         + N0[:, 2:] * np.cross(Jc[0], Jc[1]))
    ratio = np.minimum(1.0, dn / np.linalg.norm(n, axis=1))
    return np.degrees(np.arcsin(ratio) + 2 * U32 + 2.0 ** -40)


# --- the multiresolution frame (shaders/multires.comp) -----------------------------------
#
# Per fine vertex the device evaluates, at the foot point S(t_i) (inside the box, so the
# basis values are >= 0 and sum to 1 per axis), the FFD value and Jacobian of control
# points q rounded to float32 (u |q - o|), with the basis values and derivatives of
# basis_reals.glsl: the Jacobian's columns err by e_a as above (_jacobian_errors), and
# the value, a nested float32 sum of K_u K_v K_w terms with those values, by at most
#   eS = R (eB_u + eB_v + eB_w) + (K_u + K_v + K_w + 4) u R        (times 1.01)
# (basis values; the three levels of sums and products; the control points' rounding).
# After a Deformer's frame in the same submission (corrected.comp) the control points are
# fl(fl(P - o) + offset): a second rounding, u (R + |offset|), added to eS and, as
# normal_angle_bound's `dmax`, to the Jacobian's columns.
# All further steps are float32 operations on rounded data (S_u, S_v, d and the six
# coefficients each rounded once: u of themselves); with x~ = |x| + e_x, a product
# rounded once per operation and the vector forms of componentwise bounds (Minkowski:
# a componentwise bound sum_k w_k |v_k,comp| gives the norm bound sum_k w_k |v_k|):
#   S'_u = sum_a S_u,a c_a:       e_su = sum_a |S_u,a| (e_a + 3 u c~_a) + u |S_u| sum_a |c_a|   (S'_v alike)
#   c = S'_u x S'_v:              e_c  = e_su |S'_v| + |S'_u| e_sv + e_su e_sv + 4 u S'_u~ S'_v~
#                                 (each component a_y b_z - a_z b_y: 3 roundings of at most |a| |b|)
#   N_S' = c / |c|:               e_N  = 2 e_c / |c| + 4 u   (a unit vector's change; length and division)
#   p' = S' + d N_S':             e_p  = eS + |d| e_N + 3 u |d| + u (|S' - o| + |d|)
#   F_u = a_u S'_u + b_u S'_v + g_u N_S':
#                                 e_fu = |a_u| e_su + |b_u| e_sv + |g_u| e_N + 4 u (|a_u| S'_u~ + |b_u| S'_v~ + |g_u|)
#   n = F_u x F_v:                e_n  = e_fu |F_v| + |F_u| e_fv + e_fu e_fv + 4 u F_u~ F_v~
# and the angle between the device's normal and the CPU's is at most asin(e_n / |n|) plus
# 4 u for the final normalisation and 2^-40 for the CPU's double arithmetic (its values
# err by a few 1e-16 relative). Every |.| without ~ is the CPU's (double) value.

def multires_bounds(lat, frame_data, control_points, values, jacobians, offsets=None):
    """Per vertex ((V,) world units, (V,) degrees): bounds on the distance between the
    device's and the CPU's (MultiresFFD) vertices, and on the angle between their
    approximate normals, for control points ``control_points`` (the derivation above).
    ``frame_data``: ``Multires.frame_data()``; ``values``, ``jacobians``: the CPU's D and
    J at the foot points (``MultiresFFD.foot_values_jacobians``). ``offsets``: the
    correction's offsets when the device added them to the control points (a frame after
    a Deformer's). The foot points must lie in the lattice box (the basis values are then
    non-negative), after the wrap of a periodic lattice's axes.

    A periodic lattice (the extended control points, _jacobian_errors; the host wraps the
    foot points in double and rounds the local parameter once, as for any point): a twist
    seam's mirror changes the signs of S_u's and S_v's components on the host, which
    leaves every magnitude below unchanged; a shift seam's translation T (device units,
    rounded once to float32: u |T|, |T| <= |S' - o| + R since the wrapped point's image lies
    in its control points' hull) is added to the value in float32 (u |S' - o|): u (2 |S' - o|
    + R) more on every vertex."""
    foot = np.asarray(frame_data["foot_points"], float)
    if lat.periodic:
        foot = np.asarray(lat._spec.wrap_points(foot)[0], float)
    assert np.all(foot >= lat.box_min) and np.all(foot <= lat.box_max), "a foot point outside the box"
    o = 0.5 * (lat.box_min + lat.box_max)
    dmax = 0.0 if offsets is None else float(np.abs(np.asarray(offsets, float)).max(initial=0.0)) * np.sqrt(3)
    e, R, eB = _jacobian_errors(lat, foot, control_points, dmax)
    Ks = [d + 1 for d in lat.degree]
    eS = 1.01 * (R * eB.sum(axis=0) + (sum(Ks) + 4) * U32 * R + (U32 * (R + dmax) if offsets is not None else 0.0))
    J = np.asarray(jacobians, float).reshape(-1, 3, 3)
    cn = np.linalg.norm(J, axis=1)  # |c_a|, (V, 3)
    norm = lambda x: np.linalg.norm(x, axis=1)  # noqa: E731

    def image(t):
        t = np.asarray(t, float)
        at = np.abs(t)
        err = (at * (e + 3 * U32 * (cn + e))).sum(axis=1) + U32 * norm(t) * cn.sum(axis=1)
        return np.einsum("vij,vj->vi", J, t), 1.01 * err

    su1, e_su = image(frame_data["tangents_u"])
    sv1, e_sv = image(frame_data["tangents_v"])
    c = np.cross(su1, sv1)
    lc = norm(c)
    e_c = e_su * norm(sv1) + norm(su1) * e_sv + e_su * e_sv + 4 * U32 * (norm(su1) + e_su) * (norm(sv1) + e_sv)
    e_N = np.where(e_c < lc, 2 * e_c / lc + 4 * U32, 2.0)
    ns = c / lc[:, None]
    d = np.abs(np.asarray(frame_data["displacements"], float))
    S1 = np.asarray(values, float)
    e_p = eS + d * e_N + 3 * U32 * d + U32 * (norm(S1 - o) + d) + 2.0 ** -40 * (norm(S1 - o) + d)
    if any(v == "shift" for v in lat.seams.values()):
        e_p = e_p + 1.01 * U32 * (2 * norm(S1 - o) + R)
    C = np.asarray(frame_data["normal_coefficients"], float)

    def tangent(k):
        a, b, g = C[:, 3 * k], C[:, 3 * k + 1], C[:, 3 * k + 2]
        f = a[:, None] * su1 + b[:, None] * sv1 + g[:, None] * ns
        err = (np.abs(a) * e_su + np.abs(b) * e_sv + np.abs(g) * e_N
               + 4 * U32 * (np.abs(a) * (norm(su1) + e_su) + np.abs(b) * (norm(sv1) + e_sv) + np.abs(g)))
        return f, 1.01 * err

    fu, e_fu = tangent(0)
    fv, e_fv = tangent(1)
    n = norm(np.cross(fu, fv))
    e_n = e_fu * norm(fv) + norm(fu) * e_fv + e_fu * e_fv + 4 * U32 * (norm(fu) + e_fu) * (norm(fv) + e_fv)
    angle = np.degrees(np.arcsin(np.minimum(1.0, e_n / n)) + 4 * U32 + 2.0 ** -40)
    return e_p, angle
