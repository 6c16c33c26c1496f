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

A corrected volume: each step measures the volume of the positions the device holds,
so only the rounding of the last step's coordinate remains unmeasured; the volume is
linear in each coordinate (V = sum_v g_v y_v, g the cone-volume gradient), so
    |V_device - target| <= sum_v |g_v,a| E_v,a (a: the last corrected axis)
with E the bound above for one gather. An uncorrected volume carries every vertex's
error: |dV| <= sum_v sum_a |g_v,a| E_v,a with E for the whole frame.
"""
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


class Bounds:
    """The bounds of one CPU frame `c` (a deform result) on `mesh` in lattice `lat`."""

    def __init__(self, mesh, lat, c, P):
        o = 0.5 * (lat.box_min + lat.box_max)
        per_op = _basis_error(lat) + _terms(lat) + 3
        P = np.asarray(P, float).reshape(-1, 3)
        offsets = np.asarray(c.offsets, float).reshape(-1, 3)
        Y = np.asarray(c.vertices, float) - o
        steps = max(len(c.steps), 1)
        # A step's own offsets (with rounds, one step's may exceed the frame's total).
        delta = max([s["max_offset"] for s in c.steps] + [np.abs(offsets).max(initial=0.0)])
        self.step_error = U32 * (per_op * delta + np.abs(Y).max())
        # The plain FFD, then every step's gather and rounding.
        self.vertex = U32 * per_op * np.abs(P - o).max() + steps * self.step_error
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
