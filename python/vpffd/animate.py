"""Lattice animations: control points over time, deformed frame by frame.

An animator is a callable ``animator(t) -> (nu, nv, nw, 3)`` control points for
a time ``t`` in seconds, built from the rest lattice; ``animator.duration`` is
the length of the animation. ``run_animation`` deforms a mesh with every frame,
with or without the exact volume correction, restricted to chosen axes.

Length: one module because the animators and the loop that runs them are one
concept, and each of the five animators documents its parameters and units.

>>> import vpffd
>>> from vpffd.animate import Twist, run_animation
>>> cube = vpffd.shapes.box(8)
>>> lat = vpffd.Lattice.around(cube, shape=(5, 5, 5), padding=0.02)
>>> anim = run_animation(cube, lat, Twist(lat, angle=180), frames=5, axes="xy")
>>> bool(anim.max_volume_error < 1e-10)
True
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import _arrays, _core, edits
from .deformer import Deformer
from .lattice import Lattice
from .mesh import Mesh

InvalidInputError = _core.InvalidInputError

__all__ = ["Animator", "Twist", "Bend", "Taper", "BouncingBall", "Jelly", "PathOffset", "AnimationResult",
           "run_animation", "ease"]


def ease(s, kind: str = "linear"):
    """Maps normalised time ``s`` in [0, 1] to an animation weight.

    Parameters
    ----------
    s : float or ndarray
        normalised time, clipped to [0, 1].
    kind : {"linear", "smooth", "pingpong"}
        "smooth" is the C1 smoothstep (slow in, slow out); "pingpong" goes
        0 -> 1 -> 0 (smoothly), for loops.
    """
    s = np.clip(s, 0.0, 1.0)
    if kind == "linear":
        return s
    if kind == "smooth":
        return s * s * (3.0 - 2.0 * s)
    if kind == "pingpong":
        return 0.5 - 0.5 * np.cos(2.0 * np.pi * s)
    raise InvalidInputError(f"ease: expected 'linear', 'smooth' or 'pingpong', got {kind!r}")


_ease = ease  # the animators' ``ease`` arguments shadow the function


def _real(v, name: str, who: str) -> float:
    return _arrays.real(v, name, who)


def _finite(v, name: str, who: str) -> float:
    return _arrays.finite(v, name, who)


def _axis(axis, name: str, who: str) -> int:
    """Validates an axis at construction (not at the first frame)."""
    return _arrays.axis(axis, name, who)


class Animator:
    """Base class: control points of one lattice as a function of time.

    Parameters
    ----------
    lattice : Lattice
        its ``rest_points`` are the starting pose; the lattice is not modified.
    duration : float
        seconds (> 0).

    Notes
    -----
    Subclasses implement ``__call__(t)`` returning (nu, nv, nw, 3) float64.
    """

    name = "animation"

    def __init__(self, lattice: Lattice, duration: float = 1.0):
        if not isinstance(lattice, Lattice):
            raise TypeError(f"{type(self).__name__}: expected a vpffd.Lattice, got {type(lattice).__name__}")
        duration = _real(duration, "duration", type(self).__name__)
        if not (np.isfinite(duration) and duration > 0):
            raise InvalidInputError(f"{type(self).__name__}: duration must be a positive number, got {duration}")
        self.lattice = lattice
        self.rest = np.array(lattice.rest_points, dtype=np.float64)
        self.duration = duration

    def times(self, frames: int) -> np.ndarray:
        """``frames`` evenly spaced times from 0 to ``duration`` inclusive, (frames,) seconds."""
        if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or frames < 1:
            raise InvalidInputError(f"frames: expected a positive integer, got {frames!r}")
        return np.linspace(0.0, self.duration, int(frames)) if frames > 1 else np.zeros(1)

    def _t(self, t) -> float:
        t = float(t)
        if not np.isfinite(t):
            raise InvalidInputError(f"{type(self).__name__}: time must be a finite number of seconds, got {t}")
        return t

    def _s(self, t) -> float:
        return self._t(t) / self.duration

    def __call__(self, t) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{type(self).__name__}(duration={self.duration})"


class Twist(Animator):
    """Continuous twist about ``axis``: the bottom of the lattice stays, the top
    turns by ``angle * ease(t / duration)`` degrees (the paper's Figure 6).

    Parameters
    ----------
    lattice : Lattice
    angle : float
        final twist, degrees.
    axis : {"x", "y", "z"}
    ease : {"linear", "smooth", "pingpong"}
    duration : float, seconds
    """

    name = "twist"

    def __init__(self, lattice, angle: float = 360.0, axis="z", ease: str = "linear", duration: float = 1.0):
        super().__init__(lattice, duration)
        self.angle, self.axis, self.ease = _finite(angle, "angle", "Twist"), axis, ease
        _axis(axis, "axis", "Twist")  # reject a bad axis or ease name now, not at the first frame
        _ease(0.0, ease)

    def __call__(self, t):
        return edits.twist(self.rest, self.angle * float(_ease(self._s(t), self.ease)), self.axis)


class Bend(Animator):
    """Bends the lattice's extent along ``axis`` into an arc of
    ``angle * ease(t / duration)`` degrees curving towards +``toward``."""

    name = "bend"

    def __init__(self, lattice, angle: float = 90.0, axis="z", toward="x", ease: str = "linear",
                 duration: float = 1.0):
        super().__init__(lattice, duration)
        self.angle, self.axis, self.toward, self.ease = _finite(angle, "angle", "Bend"), axis, toward, ease
        if _axis(axis, "axis", "Bend") == _axis(toward, "toward", "Bend"):
            raise InvalidInputError(f"Bend: toward ({toward!r}) must differ from the bend axis ({axis!r})")
        _ease(0.0, ease)

    def __call__(self, t):
        return edits.bend(self.rest, self.angle * float(_ease(self._s(t), self.ease)), self.axis, self.toward)


class Taper(Animator):
    """Tapers across ``axis``: the top's cross-section scales from 1 to ``factor``."""

    name = "taper"

    def __init__(self, lattice, factor: float = 0.3, axis="z", ease: str = "linear", duration: float = 1.0):
        super().__init__(lattice, duration)
        self.factor, self.axis, self.ease = _finite(factor, "factor", "Taper"), axis, ease
        _axis(axis, "axis", "Taper")
        _ease(0.0, ease)

    def __call__(self, t):
        w = float(_ease(self._s(t), self.ease))
        return edits.taper(self.rest, 1.0 + (self.factor - 1.0) * w, self.axis)


class BouncingBall(Animator):
    """Squash and stretch: a ball dropped on the ground, flattened and bounced back
    (the paper's Figure 1), deterministic and periodic.

    The ball (the lattice) starts at rest where it is, ``drop`` ball heights
    above the ground, and falls under ``gravity``, stretched
    vertically in proportion to its speed. When its lowest point reaches the
    ground it keeps moving down by a penetration depth ``d(t)`` that grows under a
    constant deceleration up to ``squash * H`` (H the ball's height) and back,
    and the control points are pushed out of the ground by a smooth one-sided
    clamp: whatever would be under the ground piles up in a flat contact patch.
    Nothing moves horizontally, so a plain FFD loses volume while flattened;
    the volume correction restricted to "xy" makes it bulge sideways instead.
    With an elastic bounce the ball returns to its drop height after
    ``period`` seconds.

    Parameters
    ----------
    lattice : Lattice
    bottom : float, optional
        z of the ball's lowest rest point (mesh units); default the lattice box
        bottom. Pass ``mesh.bounds[0, 2]`` so that contact starts when the mesh
        itself touches the ground.
    drop : float
        height of the ball's bottom above the ground at the start, in ball
        heights; the ground is at ``ground = bottom - drop * height``.
    squash : float
        deepest penetration, in ball heights (0.7: the ball's top sinks to 30 %
        of its height). With the defaults a plain FFD of a sphere in an 8x8x8
        lattice loses up to 73 % (``vpffd.cli.demo`` shows the paper's key frames).
    stretch : float
        extra vertical scale at the speed of impact in flight (0.15: 15 %).
    gravity : float
        in ball heights per second squared (default 9.81 / 2, a 2 m ball on Earth).
    bounces : int
        number of periods in ``duration``.
    """

    name = "bouncing ball"

    def __init__(self, lattice, bottom=None, drop: float = 0.5, squash: float = 0.7, stretch: float = 0.15,
                 gravity: float = 4.905, bounces: int = 1):
        if not isinstance(lattice, Lattice):
            raise TypeError(f"BouncingBall: expected a vpffd.Lattice, got {type(lattice).__name__}")
        if isinstance(bounces, bool) or not isinstance(bounces, (int, np.integer)) or bounces < 1:
            raise InvalidInputError(f"BouncingBall: bounces must be a positive integer, got {bounces!r}")
        rest = np.asarray(lattice.rest_points)
        drop, squash, stretch, gravity = (_real(v, nm, "BouncingBall") for nm, v in (
            ("drop", drop), ("squash", squash), ("stretch", stretch), ("gravity", gravity)))
        if bottom is not None:
            bottom = _real(bottom, "bottom", "BouncingBall")
        for nm, v in (("drop", drop), ("squash", squash), ("gravity", gravity)):
            if not (np.isfinite(v) and v > 0):
                raise InvalidInputError(f"BouncingBall: {nm} must be positive, got {v}")
        if not (np.isfinite(stretch) and stretch >= 0):
            raise InvalidInputError(f"BouncingBall: stretch must be >= 0, got {stretch}")
        self.bottom = float(lattice.box_min[2] if bottom is None else bottom)
        self.height = float(lattice.box_max[2] - self.bottom)
        if not (np.isfinite(self.height) and self.height > 0):
            raise InvalidInputError(f"BouncingBall: bottom must be a finite height below the top of the lattice, "
                                    f"got {bottom}")
        self.drop, self.squash, self.stretch, self.gravity = float(drop), float(squash), float(stretch), float(gravity)
        H = self.height
        self.v0 = np.sqrt(2.0 * self.gravity * self.drop) * H          # impact speed, mesh units / s
        self.t_fall = np.sqrt(2.0 * self.drop / self.gravity)          # s
        self.decel = self.v0 ** 2 / (2.0 * self.squash * H)           # mesh units / s^2
        self.t_contact = 2.0 * self.v0 / self.decel                    # s
        self.period = 2.0 * self.t_fall + self.t_contact
        self.bounces = int(bounces)
        super().__init__(lattice, self.period * self.bounces)
        self._floor = float(min(rest[..., 2].min(), self.bottom))
        self.ground = self.bottom - self.drop * self.height

    def state(self, t):
        """(lift, speed, depth) at time t: height of the ball's bottom above the
        ground (mesh units, >= 0 in flight), its speed, and the penetration
        depth (>= 0 in contact)."""
        tau = self._t(t) % self.period
        H = self.height
        if tau < self.t_fall:                                   # falling
            lift = self.drop * H - 0.5 * self.gravity * H * tau ** 2
            return max(lift, 0.0), self.gravity * H * tau, 0.0
        tau -= self.t_fall
        if tau < self.t_contact:                                # on the ground
            return 0.0, 0.0, max(self.v0 * tau - 0.5 * self.decel * tau ** 2, 0.0)
        tau = self.t_fall - (tau - self.t_contact)             # rising: the fall backwards
        return max(self.drop * H - 0.5 * self.gravity * H * tau ** 2, 0.0), self.gravity * H * tau, 0.0

    def flattening(self, t) -> float:
        """Penetration depth at time ``t`` relative to the ball's height (0 in flight)."""
        return self.state(t)[2] / self.height

    def __call__(self, t):
        lift, speed, depth = self.state(t)
        P = self.rest.copy()
        H = self.height
        # Stretch fades out in the last quarter height above the ground, so the
        # shape is continuous at the moment of impact.
        s = 1.0 + self.stretch * (speed / self.v0) * min(1.0, lift / (0.25 * H)) if self.v0 > 0 else 1.0
        # Heights are measured from the lattice floor (the lowest rest control
        # layer, a padding g below the mesh) so that the clamp is the identity
        # for every control point when the penetration is zero.
        g = self.bottom - self._floor
        h = s * (P[..., 2] - self.bottom) + g + lift - depth
        if depth > 0:
            # One-sided C1 clamp: identity above the band w, exponential pile-up
            # below it, so no control point sinks under the floor; the band
            # shrinks to nothing at the start and end of contact (continuity).
            w = 0.3 * depth
            h = np.where(h < w, w * np.exp(np.minimum(h - w, 0.0) / w), h)
        P[..., 2] = self.ground - g + h
        return P


class Jelly(Animator):
    """A jelly block: the lattice's control points as unit masses joined by
    springs to their 26 lattice neighbours (rest lengths from the rest lattice),
    the bottom layer pinned, set wobbling by an initial velocity kick.

    Integrated with symplectic Euler at a fixed step ``dt``, so a given set of
    parameters always gives the same frames.

    Parameters
    ----------
    lattice : Lattice
    kick : (3,) float
        initial velocity of the top layer in lattice heights per second; lower
        layers get it in proportion to their height (a shear-and-squash push).
    stiffness : float
        spring constant of a spring of the mean rest length, 1/s^2 (unit
        masses); the others scale with 1 / rest length, like rods of one material.
    damping : float
        velocity damping, 1/s.
    axis : {"x", "y", "z"}
        the up axis; the layer at its minimum is pinned.
    duration, dt : float, seconds
    """

    name = "jelly"

    def __init__(self, lattice, kick=(0.8, 0.0, -0.8), stiffness: float = 300.0, damping: float = 1.5,
                 axis="z", duration: float = 2.0, dt: float = 1.0 / 240.0):
        super().__init__(lattice, duration)
        a = _axis(axis, "axis", "Jelly")
        stiffness, damping, dt = (_real(v, nm, "Jelly") for nm, v in (
            ("stiffness", stiffness), ("damping", damping), ("dt", dt)))
        try:
            kick = np.asarray(kick, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):
            raise TypeError(f"Jelly: kick must be three real numbers, got {kick!r}") from None
        if kick.shape != (3,) or not np.all(np.isfinite(kick)):
            raise InvalidInputError(f"Jelly: kick must be three finite numbers, got {kick}")
        for nm, v in (("stiffness", stiffness), ("dt", dt)):
            if not (np.isfinite(v) and v > 0):
                raise InvalidInputError(f"Jelly: {nm} must be positive, got {v}")
        if not (np.isfinite(damping) and damping >= 0):
            raise InvalidInputError(f"Jelly: damping must be >= 0, got {damping}")
        self.k, self.c, self.dt = float(stiffness), float(damping), float(dt)
        shape = self.rest.shape[:3]
        X0 = self.rest.reshape(-1, 3)
        idx = np.arange(X0.shape[0]).reshape(shape)
        pairs = []
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                for dk in (-1, 0, 1):
                    if (di, dj, dk) <= (0, 0, 0):  # each unordered pair once
                        continue
                    a_ = idx[max(0, -di):shape[0] - max(0, di), max(0, -dj):shape[1] - max(0, dj),
                             max(0, -dk):shape[2] - max(0, dk)]
                    b_ = idx[max(0, di):shape[0] + min(0, di), max(0, dj):shape[1] + min(0, dj),
                             max(0, dk):shape[2] + min(0, dk)]
                    pairs.append(np.stack([a_.ravel(), b_.ravel()], axis=1))
        self.springs = np.concatenate(pairs)
        self.rest_lengths = np.linalg.norm(X0[self.springs[:, 1]] - X0[self.springs[:, 0]], axis=1)
        up = X0[:, a]
        lo, hi = up.min(), up.max()
        self.pinned = up <= lo + 1e-12 * max(1.0, abs(hi - lo))
        height = (up - lo) / (hi - lo)
        extent = float(hi - lo)
        self.v_init = height[:, None] * kick[None, :] * extent
        self.v_init[self.pinned] = 0.0
        self._traj = None

    def _simulate(self):
        n_steps = int(np.ceil(self.duration / self.dt)) + 1
        X = self.rest.reshape(-1, 3).copy()
        V = self.v_init.copy()
        i, j = self.springs[:, 0], self.springs[:, 1]
        # k ~ 1/L as for rods of one material: long diagonals are softer than edges
        kk = self.k / self.rest_lengths * self.rest_lengths.mean()
        traj = np.empty((n_steps + 1,) + X.shape)
        traj[0] = X
        free = ~self.pinned
        with np.errstate(over="ignore", invalid="ignore"):  # an unstable run is reported below
            for s in range(n_steps):
                d = X[j] - X[i]
                L = np.linalg.norm(d, axis=1)
                f = (kk * (L - self.rest_lengths) / np.maximum(L, 1e-300))[:, None] * d
                F = np.zeros_like(X)
                np.add.at(F, i, f)
                np.add.at(F, j, -f)
                V[free] += self.dt * (F[free] - self.c * V[free])
                X[free] += self.dt * V[free]
                traj[s + 1] = X
        if not np.isfinite(traj).all():
            raise InvalidInputError(f"Jelly: the simulation blew up (stiffness {self.k:g} is too stiff for the step "
                                    f"dt {self.dt:g} s); lower the stiffness or the step")
        self._traj = traj

    def __call__(self, t):
        if self._traj is None:
            self._simulate()
        x = min(max(self._t(t), 0.0), self.duration) / self.dt
        i = min(int(np.floor(x)), self._traj.shape[0] - 2)
        f = x - i
        return ((1.0 - f) * self._traj[i] + f * self._traj[i + 1]).reshape(self.rest.shape)


class PathOffset:
    """Moves an object through a lattice's rest box instead of moving control points
    (the whales circling a ring, ants walking a Moebius band, a car over terrain):
    rest positions X(t) = X + o(t), o(t) = speed * t * direction.

    Feed ``offset(t)`` to ``Deformer.set_rest_offsets`` (every object by the same
    offset; on "vulkan" only the offset goes to the device), or ``positions(X, t)``
    to ``Deformer.set_rest_vertices`` (or ``Lattice.deform_points``), each frame;
    the control points stay as they are.

    Parameters
    ----------
    lattice : vpffd.Lattice
    direction : {"x", "y", "z"} or (3,) float
        an axis, or a direction in rest space (normalised here).
    speed : float
        world units per second along ``direction`` (any sign).
    wrap : bool
        along the lattice's periodic axes, reduce the offset by whole periods so it
        stays bounded however long the animation runs, without changing what any
        point maps to: the box's extent L for the "closed" seam, 2 L for "twist"
        (one lap comes back mirrored), and not at all for "shift" (there
        D(x + L) = D(x) + L: the object really travels on). The object itself is
        moved as a whole (not each vertex into the box), so its rest volume stays.
        Along open axes the offset is never wrapped (the object leaves the box, and
        the Deformer then raises unless ``outside="extrapolate"``).
    """

    def __init__(self, lattice, direction="x", speed: float = 1.0, wrap: bool = True):
        if not isinstance(lattice, Lattice):
            raise TypeError(f"PathOffset: expected a vpffd.Lattice, got {type(lattice).__name__}")
        if isinstance(direction, str) or isinstance(direction, (int, np.integer)):
            d = np.zeros(3)
            d[_axis(direction, "direction", "PathOffset")] = 1.0
        else:
            try:
                d = np.asarray(direction, dtype=np.float64)
            except (TypeError, ValueError):
                raise InvalidInputError(f"PathOffset: direction must be an axis name or 3 numbers, got "
                                        f"{direction!r}") from None
            if d.shape != (3,) or not np.isfinite(d).all() or not np.linalg.norm(d) > 0:
                raise InvalidInputError(f"PathOffset: direction must be an axis name or 3 finite numbers, not all "
                                        f"zero, got {direction!r}")
            d = d / np.linalg.norm(d)
        if not isinstance(wrap, (bool, np.bool_)):
            raise TypeError(f"PathOffset: wrap must be a bool, got {type(wrap).__name__}")
        self.lattice = lattice
        self.direction = d
        self.speed = _finite(speed, "speed", "PathOffset")
        self.wrap = bool(wrap)
        ext = lattice.box_max - lattice.box_min
        seams = lattice.seams
        # Per axis, the period of the map x -> D(x) (0: none to wrap by).
        self.periods = np.array([{"closed": ext[a], "twist": 2 * ext[a]}.get(seams.get("xyz"[a]), 0.0)
                                 for a in range(3)])

    def offset(self, t) -> np.ndarray:
        """(3,) rest-space offset at time ``t`` seconds."""
        t = _finite(t, "time", "PathOffset")
        o = self.speed * t * self.direction
        if self.wrap:
            p = self.periods
            o = np.where(p > 0, o - p * np.floor(o / np.where(p > 0, p, 1.0)), o)
        return o

    def positions(self, rest_vertices, t) -> np.ndarray:
        """(n, 3) rest positions at time ``t``: ``rest_vertices`` ((n, 3) or a Mesh)
        plus ``offset(t)``. The input is not modified."""
        if hasattr(rest_vertices, "vertices"):
            rest_vertices = rest_vertices.vertices
        from . import _arrays
        X = _arrays.points(rest_vertices, "PathOffset.positions: rest_vertices")
        return X + self.offset(t)

    def __call__(self, rest_vertices, t) -> np.ndarray:
        return self.positions(rest_vertices, t)

    def __repr__(self) -> str:
        return (f"PathOffset(direction={self.direction.tolist()}, speed={self.speed}, wrap={self.wrap}, "
                f"periods={self.periods.tolist()})")


@dataclass
class AnimationResult:
    """Frames of one animation.

    Attributes
    ----------
    times : (T,) float, seconds
    control_points : (T, nu, nv, nw, 3) float64
        the animator's control points (before correction).
    corrected_points : (T, nu, nv, nw, 3) float64
        after correction (equal to ``control_points`` without preservation).
    vertices : (T, V, 3) float64 or None
        the deformed mesh per frame (None with ``keep_vertices=False``).
    volumes : (T,) float
        enclosed volume of the frames as deformed (corrected or not).
    volumes_plain : (T,) float
        enclosed volume after the plain FFD of every frame.
    rest_volume : float
        the enclosed volume of the undeformed mesh. NaN for an open mesh (only
        possible with ``preserve=False``): an open mesh bounds no volume, so
        ``volume_change``, ``volume_change_plain`` and ``max_volume_error`` are
        NaN too.
    preserve : bool
    axes : str
        the correction axes ("" without preservation).
    """
    times: np.ndarray
    control_points: np.ndarray
    corrected_points: np.ndarray
    vertices: object
    volumes: np.ndarray
    volumes_plain: np.ndarray
    rest_volume: float
    preserve: bool
    axes: str
    faces: np.ndarray = field(default=None, repr=False)

    def __repr__(self) -> str:
        T = len(self.times)
        V = "not kept" if self.vertices is None else f"{np.shape(self.vertices)[1]} vertices"
        kept = f"preserved along {self.axes}" if self.preserve else "not preserved"
        span = f"{self.times[0]:.3g}..{self.times[-1]:.3g} s" if T else "no frames"
        ch = self.volume_change_plain
        worst = f"{100 * np.nanmax(np.abs(ch)):.2f} %" if T and np.isfinite(ch).any() else "n/a"
        return (f"AnimationResult({T} frames, {span}, {V}, lattice "
                f"{'x'.join(map(str, np.shape(self.control_points)[1:4]))}, volume {kept}\n"
                f"  rest volume {self.rest_volume:.6g}; largest change of the plain FFD {worst}; "
                f"largest error of the frames {self.max_volume_error if T else float('nan'):.1e})")

    @property
    def volume_change(self) -> np.ndarray:
        """(T,) relative volume change of the frames against the rest volume
        (NaN for an open mesh, which bounds no volume)."""
        return (self.volumes - self.rest_volume) / self.rest_volume

    @property
    def volume_change_plain(self) -> np.ndarray:
        """(T,) relative volume change of the plain FFD frames (NaN for an open mesh)."""
        return (self.volumes_plain - self.rest_volume) / self.rest_volume

    @property
    def max_volume_error(self) -> float:
        """Largest |volume - rest| / |rest| over the frames (NaN for an open
        mesh, which bounds no volume)."""
        return float(np.max(np.abs(self.volume_change)))

    @property
    def label(self) -> str:
        return f"preserved ({self.axes})" if self.preserve else "plain FFD"

    def mesh(self, frame: int) -> Mesh:
        """The deformed mesh of one frame (needs ``keep_vertices=True``);
        ``frame`` in [-T, T), negative counting from the end as in Python."""
        if self.vertices is None:
            raise InvalidInputError("AnimationResult.mesh: the run kept no vertices (keep_vertices=False)")
        if isinstance(frame, (bool, np.bool_)) or not isinstance(frame, (int, np.integer)):
            raise TypeError(f"AnimationResult.mesh: frame must be an integer, got {type(frame).__name__} {frame!r}")
        T = len(self.vertices)
        if not -T <= frame < T:
            raise IndexError(f"AnimationResult.mesh: frame {frame} is out of range; this run has {T} frames "
                             f"(valid: 0..{T - 1}, or -{T}..-1 from the end)")
        return Mesh(self.vertices[frame], self.faces)


def run_animation(mesh, lattice: Lattice, animator, frames=24, axes: str = "xyz", preserve: bool = True,
                  backend: str = "auto", keep_vertices: bool = True, deformer: Deformer = None,
                  progress=None) -> AnimationResult:
    """Deforms ``mesh`` with every frame of ``animator``.

    Parameters
    ----------
    mesh : Mesh or (vertices, faces)
        closed when ``preserve`` is on.
    lattice : Lattice
        the lattice the animator was built on (the mesh must lie in its box).
    animator : callable t -> (nu, nv, nw, 3)
        an ``Animator`` or any function of time in seconds.
    frames : int or array_like of float
        a frame count (evenly spaced over ``animator.duration``, both ends
        included) or the times in seconds.
    axes : str
        correction axes: "xyz", "xy" (horizontal only, the paper's bouncing
        ball), "z", ...; ignored without ``preserve``.
    preserve : bool
        correct every frame's volume to the rest volume.
    backend : str
        Deformer backend (see ``available_backends()``).
    keep_vertices : bool
        keep the (T, V, 3) vertices (memory: 24 bytes per vertex and frame).
    deformer : Deformer, optional
        reuse one built for ``mesh`` and ``lattice`` (saves the embedding).
    progress : callable, optional
        called as ``progress(done, total)`` after every frame.

    Returns
    -------
    AnimationResult
    """
    if not isinstance(preserve, (bool, np.bool_)):
        raise TypeError(f"run_animation: preserve must be True or False, got {type(preserve).__name__} {preserve!r}")
    if deformer is None:
        deformer = Deformer(mesh, lattice, backend=backend)
    elif not isinstance(deformer, Deformer) or deformer.lattice is not lattice or (
            Mesh.from_any(mesh) is not deformer.mesh and not (
                np.array_equal(Mesh.from_any(mesh).vertices, deformer.mesh.vertices)
                and np.array_equal(Mesh.from_any(mesh).faces, deformer.mesh.faces))):
        raise InvalidInputError("run_animation: deformer must be a Deformer of this mesh and this lattice")
    if np.ndim(frames) == 0:
        if not hasattr(animator, "times"):
            raise InvalidInputError("run_animation: give the frame times for an animator without times()")
        times = animator.times(frames)
    else:
        times = np.asarray(frames, dtype=np.float64).reshape(-1)
        if times.size == 0 or not np.all(np.isfinite(times)):
            raise InvalidInputError("run_animation: frames must be a count or finite times")
    preserve = bool(preserve)
    T = times.size
    shape = lattice.shape
    cps = np.empty((T, *shape, 3))
    corrected = np.empty_like(cps)
    verts = np.empty((T, deformer.mesh.n_vertices, 3)) if keep_vertices else None
    vols = np.empty(T)
    plain = np.empty(T)
    for f, t in enumerate(times):
        P = np.asarray(animator(t), dtype=np.float64)
        if P.size != cps[f].size:
            raise InvalidInputError(f"run_animation: the animator gave control points of shape {P.shape} at t = {t:g} "
                                    f"s, but the lattice is {'x'.join(map(str, shape))} (expected {(*shape, 3)}); "
                                    f"was it built on another lattice?")
        P = P.reshape(*shape, 3)
        r = deformer.deform(P, preserve_volume=preserve, axes=axes if preserve else "xyz")
        cps[f], corrected[f] = P, r.control_points
        if keep_vertices:
            verts[f] = r.vertices
        vols[f], plain[f] = r.volume, r.volume_before
        if progress is not None:
            progress(f + 1, T)
    return AnimationResult(times=times, control_points=cps, corrected_points=corrected, vertices=verts,
                           volumes=vols, volumes_plain=plain,
                           rest_volume=deformer.rest_volume if deformer.mesh.is_closed else float("nan"),
                           preserve=preserve, axes=axes if preserve else "", faces=np.array(deformer.mesh.faces))
