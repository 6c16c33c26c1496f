"""Trivariate B-spline lattices."""
from __future__ import annotations

import math
import os

import numpy as np

from . import _arrays, _core

InvalidInputError = _core.InvalidInputError

# 100 M control points are 2.4 GB per (N, 3) array; beyond that a lattice is a mistake.
_MAX_CONTROL_POINTS = 100_000_000


def _triple(x, name, kind=int):
    if np.ndim(x) == 0:
        x = (x, x, x)
    x = tuple(x)
    if len(x) != 3:
        raise InvalidInputError(f"{name}: expected one value or three, got {len(x)}")
    for v in x:
        if kind is int and (isinstance(v, bool) or not isinstance(v, (int, np.integer))):
            raise TypeError(f"{name}: expected integers, got {v!r}")
    return tuple(kind(v) for v in x)


def _knot_vectors(knots) -> list:
    if isinstance(knots, (str, bytes)) or not hasattr(knots, "__len__") or len(knots) != 3:
        raise InvalidInputError("Lattice: knots must be three 1-D sequences (one knot vector per axis)")
    out = []
    for a, k in enumerate(knots):
        try:
            k = np.asarray(k, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise InvalidInputError(f"Lattice: knots along {'xyz'[a]} are not numbers ({e})") from None
        if k.ndim != 1:
            raise InvalidInputError(f"Lattice: knots along {'xyz'[a]} must be 1-D, got shape {k.shape}")
        out.append(k.tolist())
    return out


_SEAMS = ("shift", "closed", "twist")


def _periodic_axes(periodic) -> tuple:
    """Axis indices named by ``periodic`` (None, "", "x", "xz", or a sequence of axis names)."""
    if periodic is None:
        return ()
    if isinstance(periodic, str):
        names = list(periodic)
    elif isinstance(periodic, (list, tuple)) and all(isinstance(a, str) for a in periodic):
        names = list(periodic)
    else:
        raise InvalidInputError(f"Lattice: periodic must name axes as a string such as 'x' or 'xz', "
                                f"got {periodic!r}")
    out = []
    for a in names:
        if a not in ("x", "y", "z"):
            raise InvalidInputError(f"Lattice: periodic names axis {a!r}; the axes are 'x', 'y' and 'z' "
                                    f"(got periodic={periodic!r})")
        if "xyz".index(a) in out:
            raise InvalidInputError(f"Lattice: periodic names axis {a!r} twice (got periodic={periodic!r})")
        out.append("xyz".index(a))
    return tuple(sorted(out))


def _seams(seam, periodic: tuple) -> list:
    """Per axis "none" or the seam of a periodic axis, from one name or a dict per axis."""
    out = ["none"] * 3
    if isinstance(seam, dict):
        for k in seam:
            if k not in ("x", "y", "z") or "xyz".index(k) not in periodic:
                raise InvalidInputError(f"Lattice: seam names axis {k!r}, which is not periodic "
                                        f"(periodic axes: {''.join('xyz'[a] for a in periodic) or 'none'})")
        per_axis = {a: seam.get("xyz"[a], "shift") for a in periodic}
    elif isinstance(seam, str):
        per_axis = {a: seam for a in periodic}
    else:
        raise InvalidInputError(f"Lattice: seam must be one of {_SEAMS} or a dict axis -> seam, got {seam!r}")
    for a, v in per_axis.items():
        if v not in _SEAMS:
            raise InvalidInputError(f"Lattice: seam along {'xyz'[a]} must be one of {_SEAMS}, got {v!r}")
        out[a] = v
    return out


# What a lattice of N control points costs: its rest and current points (2 x 24 bytes)
# and the temporary the rest points are built in (24 bytes).
_LATTICE_BYTES_PER_POINT = 72


def _available_memory() -> int | None:
    """Bytes the OS says can still be allocated without swapping (Linux), or None."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def _check_memory(n_points: int, what: str, bytes_per_point: int, extra_bytes: int = 0) -> None:
    """Refuses up front, with the figures, work that could not fit in memory
    (instead of a MemoryError or the OOM killer half-way through)."""
    need = n_points * bytes_per_point + extra_bytes
    avail = _available_memory()
    if avail is not None and need > avail:
        raise InvalidInputError(
            f"{what}: {n_points:,} control points need about {need / 2**30:.1f} GiB "
            f"({bytes_per_point} bytes each"
            + (f", plus {extra_bytes / 2**30:.1f} GiB for the mesh" if extra_bytes else "")
            + f"), but only {avail / 2**30:.1f} GiB of memory is available")


class Lattice:
    """A trivariate B-spline lattice over an axis-aligned world box.

    The box ``[box_min, box_max]`` is mapped affinely onto the parameter domain
    ``[t_d, t_n]`` of each axis' knot vector; a point keeps that parameter for
    ever, and the deformed point is ``sum_ijk B_i(u) B_j(v) B_k(w) P_ijk``.

    Parameters
    ----------
    box_min, box_max : (3,) float
        world-space corners (units of the mesh).
    shape : int or (nu, nv, nw), optional
        control points per axis, each at least degree + 1; default (8, 8, 8), or
        what the knots give (n = len(knots) - degree - 1) when knots are passed.
    degree : int or (du, dv, dw), 1..5
    knots : None or three 1-D arrays
        knot vectors of n + degree + 1 values (any non-decreasing sequence with
        interior multiplicity <= degree); default open-uniform (clamped) on [0, 1].
        Not with ``periodic`` (periodic axes have uniform knots).
    periodic : str, optional
        axes along which the lattice is periodic, e.g. "x" or "xz". Along such an
        axis the spline has uniform unclamped knots and ``shape`` counts the
        *distinct* control points (at least degree + 1); the last ``degree``
        slices of the extended lattice repeat the first ones, so the map has no
        seam (C^{degree-1}), and a rest point and the same point moved by the
        box's extent along that axis map to the same place (rest points are
        wrapped into the box along periodic axes; nothing is outside along them).
    seam : {"shift", "closed", "twist"} or dict axis -> seam
        how each periodic axis closes: "shift" (default) repeats the first
        slices moved by the box's extent, so the rest lattice is the identity
        and the deformation tiles space; "closed" repeats them in place (a net
        closed on itself: ``edits.ring``); "twist" repeats them with the other
        two axes' indices reversed (a half-twisted band: ``edits.mobius``; the
        two other axes must not be periodic; a point wrapped an odd number of
        times has its two other coordinates mirrored in the box).

    Attributes
    ----------
    control_points : ndarray (nu, nv, nw, 3) float64, writable
        the current control points (the distinct ones of a periodic lattice);
        starts at ``rest_points``.
    rest_points : ndarray (nu, nv, nw, 3) float64, read-only
        control points at the Greville abscissae: the identity deformation,
        except across a "closed" or "twist" seam (there they are only a start
        for ``edits.ring`` / ``edits.mobius``).
    """

    def __init__(self, box_min, box_max, shape=None, degree=3, knots=None, periodic=None, seam="shift"):
        box_min = _arrays.vector3(box_min, "Lattice: box_min")
        box_max = _arrays.vector3(box_max, "Lattice: box_max")
        degree = _triple(degree, "Lattice: degree")
        per = _periodic_axes(periodic)
        seams = _seams(seam, per)
        if knots is not None and per:
            raise InvalidInputError("Lattice: knots cannot be given with periodic: periodic axes use uniform "
                                    "unclamped knots; leave knots out")
        if knots is not None:
            knots = _knot_vectors(knots)
            from_knots = tuple(len(k) - d - 1 for k, d in zip(knots, degree))
            if shape is None:
                shape = from_knots
            elif _triple(shape, "Lattice: shape") != from_knots:
                raise InvalidInputError(
                    f"Lattice: shape {_triple(shape, 'Lattice: shape')} does not match the knots, which give "
                    f"{from_knots} control points for degree {degree} (n = len(knots) - degree - 1); "
                    f"pass knots of n + degree + 1 values, or leave shape out")
        shape = _triple((8, 8, 8) if shape is None else shape, "Lattice: shape")
        for a, (n, d) in enumerate(zip(shape, degree)):
            if not 1 <= d <= 5:
                raise InvalidInputError(f"Lattice: degree {d} along {'xyz'[a]} not in [1, 5]")
            if n < d + 1:
                if a in per:
                    raise InvalidInputError(
                        f"Lattice: {n} distinct control points along periodic axis {'xyz'[a]} are too few for "
                        f"degree {d} (need at least degree + 1 = {d + 1}, or a point would be tied to itself)")
                raise InvalidInputError(
                    f"Lattice: shape {n} along {'xyz'[a]} is too small for degree {d} (need at least {d + 1})")
        n_total = int(np.prod([int(n) + (d if a in per else 0) for a, (n, d) in enumerate(zip(shape, degree))],
                              dtype=object))
        if n_total > _MAX_CONTROL_POINTS:
            raise InvalidInputError(f"Lattice: shape {shape} has {n_total:,} control points; at most "
                                    f"{_MAX_CONTROL_POINTS:,} are supported (each costs 24 bytes per array)")
        _check_memory(n_total, "Lattice", _LATTICE_BYTES_PER_POINT)
        if knots is None:
            knots = [_core.periodic_uniform_knots(n, d) if a in per else _core.clamped_uniform_knots(n, d)
                     for a, (n, d) in enumerate(zip(shape, degree))]
        self._spec = _core.LatticeSpec(list(degree), knots, box_min, box_max, seams)
        self.shape = tuple(self._spec.distinct_shape)
        self.degree = degree
        ext = tuple(self._spec.shape)
        # The distinct points are the extended lattice's first ones along each axis.
        rest = np.ascontiguousarray(self._spec.rest_control_points().reshape(*ext, 3)[
            :self.shape[0], :self.shape[1], :self.shape[2]])
        rest.setflags(write=False)
        self._rest = rest
        self.control_points = rest.copy()

    @classmethod
    def around(cls, points, shape=None, degree=3, padding=0.05, knots=None, periodic=None,
               seam="shift") -> "Lattice":
        """The identity lattice around the bounding box of ``points`` ((n, 3) or a
        Mesh), enlarged on each side by ``padding`` times the box's extent.

        Raises InvalidInputError when the points have no extent along an axis
        (a flat point set cannot be embedded in a solid lattice)."""
        if hasattr(points, "vertices"):
            points = points.vertices
        P = _arrays.points(points, "Lattice.around: points")
        padding = _arrays.positive(padding, "padding", "Lattice.around", allow_zero=True)
        lo, hi = _arrays.bounds(P)
        ext = hi - lo
        for a in range(3):
            if not ext[a] > 0:
                raise InvalidInputError(f"Lattice.around: the points have zero extent along {'xyz'[a]}")
        return cls(lo - padding * ext, hi + padding * ext, shape=shape, degree=degree, knots=knots,
                   periodic=periodic, seam=seam)

    # --- structure ------------------------------------------------------------
    @property
    def knots(self) -> tuple:
        """Three knot vectors (float64 arrays)."""
        return tuple(np.asarray(k) for k in self._spec.knots)

    @property
    def box_min(self) -> np.ndarray:
        return np.array(self._spec.box_min)

    @property
    def box_max(self) -> np.ndarray:
        return np.array(self._spec.box_max)

    @property
    def n_control_points(self) -> int:
        """Control points the user sets (the distinct ones of a periodic lattice)."""
        # math.prod, not np.prod: read on every frame, where np.prod's ~15 us was a few
        # per cent of a small mesh's frame.
        return int(math.prod(self.shape))

    @property
    def periodic(self) -> str:
        """The periodic axes, e.g. "x"; "" for none."""
        return "".join("xyz"[a] for a, s in enumerate(self._spec.seams) if s != "none")

    @property
    def seams(self) -> dict:
        """Periodic axis -> its seam ("shift", "closed" or "twist")."""
        return {"xyz"[a]: s for a, s in enumerate(self._spec.seams) if s != "none"}

    @property
    def extended_shape(self) -> tuple:
        """Control points per axis of the extended lattice the spline evaluates: ``shape``
        plus ``degree`` along each periodic axis."""
        return tuple(self._spec.shape)

    def expanded_control_points(self, control_points=None) -> np.ndarray:
        """(nu + du, nv, nw, 3) (etc.: ``extended_shape``) control points of the extended
        lattice: the distinct ones followed, along each periodic axis, by the tied
        copies of the first ``degree`` slices (moved by the box's extent on a "shift"
        seam, mirrored across on a "twist" seam). The same array for a lattice
        without periodic axes."""
        return self._expand(self._control(control_points)).reshape(*self.extended_shape, 3)

    def _expand(self, P) -> np.ndarray:
        """(N_ext, 3) extended control points of checked distinct ones (N, 3)."""
        return self._spec.expand_control_points(P) if self.periodic else P

    def _fold_matrix(self):
        """(N_ext, N) scipy CSR 0/1 matrix: extended control point -> the distinct one it copies."""
        import scipy.sparse as sp
        src = np.asarray(self._spec.tie_sources(), dtype=np.int64)
        return sp.csr_matrix((np.ones(len(src)), (np.arange(len(src)), src)),
                             shape=(len(src), self.n_control_points))

    def _linear_basis(self, B, what: str):
        """A basis matrix over the extended points as one over the distinct points;
        refused where the map is not linear in them (a "shift" seam adds a constant)."""
        if not self.periodic:
            return B
        shifted = [a for a, s in self.seams.items() if s == "shift"]
        if shifted:
            raise InvalidInputError(
                f"{what}: with the 'shift' seam along {''.join(shifted)} the deformation is affine, not linear, "
                f"in the distinct control points (the tied copies add the box's extent), so no basis matrix "
                f"B gives B @ control_points; use deform_points, or seam='closed'")
        return self._fold_columns(B)

    def _fold_columns(self, B):
        """Columns of a basis matrix over the extended points summed onto the distinct
        ones: how far each distinct point (with its copies) moves each row's point, for
        any seam (its support; the "shift" constant is not in it)."""
        return (B @ self._fold_matrix()).tocsr() if self.periodic else B

    @property
    def rest_points(self) -> np.ndarray:
        """(nu, nv, nw, 3) identity control points, read-only."""
        return self._rest

    @property
    def center(self) -> np.ndarray:
        return 0.5 * (self.box_min + self.box_max)

    def reset(self) -> None:
        """Puts the control points back at rest."""
        self.control_points = self._rest.copy()

    def copy(self) -> "Lattice":
        other = object.__new__(Lattice)
        other.__dict__.update(self.__dict__)
        other.control_points = np.array(self.control_points, dtype=np.float64)
        return other

    def parameters(self, points) -> np.ndarray:
        """(n, 3) parameters (u, v, w) of world points (wrapped into the box first along
        periodic axes)."""
        X = _arrays.points(points, "Lattice.parameters: points")
        if self.periodic:
            X = self._spec.wrap_points(X)[0]
        return self._spec.parameters(X)

    def deform_points(self, points, control_points=None, outside="error", out=None) -> np.ndarray:
        """Plain FFD of arbitrary rest-space points: (n, 3) -> (n, 3).

        ``outside='extrapolate'`` continues the boundary polynomial pieces for points
        outside the box instead of raising. Along periodic axes nothing is outside:
        points are wrapped into the box (see the class's ``seam``). ``out``: an
        (n, 3) float64 C-contiguous writable array to write the result into (and
        return), sharing no memory with ``points`` or the control points."""
        P = self._control(control_points)
        X = _arrays.points(points, "Lattice.deform_points: points")
        out = _arrays.out_array(out, X.shape[0], "Lattice.deform_points: out",
                                [("points", X), ("control_points", P), ("points", points),
                                 ("control_points", control_points)])
        return _core.ffd_points(self._spec, self._expand(P), X, outside, 0, out)

    def basis_matrix(self, points, outside="error"):
        """(n, N) scipy CSR matrix of the basis functions at rest-space points:
        ``basis_matrix(X) @ control_points.reshape(-1, 3) == deform_points(X)``.
        Row i is the constraint row of point i in the paper's Problem 2.
        Periodic lattices: columns are the distinct control points; refused with a
        "shift" seam (the map is affine in them there)."""
        import scipy.sparse as sp
        X = _arrays.points(points, "Lattice.basis_matrix: points")
        data, indices, indptr, shape = _core.point_basis_matrix(self._spec, X, outside)
        return self._linear_basis(sp.csr_matrix((data, indices, indptr), shape=shape), "Lattice.basis_matrix")

    def _control(self, control_points) -> np.ndarray:
        cp = self.control_points if control_points is None else control_points
        return _arrays.control_points(cp, self.n_control_points, self.shape)

    def _repr_png_(self):
        """Jupyter picture: the box surface through the current control points, with
        its volume in the caption; None without Embree."""
        from .notebook import lattice_png
        return lattice_png(self)

    def __repr__(self) -> str:
        per = f", periodic={self.periodic!r}, seam={self.seams!r}" if self.periodic else ""
        return (f"Lattice(shape={self.shape}, degree={self.degree}, box_min={self.box_min.tolist()}, "
                f"box_max={self.box_max.tolist()}{per})")
