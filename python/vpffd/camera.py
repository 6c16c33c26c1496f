"""A pinhole camera: pixel rays, projection, framing a mesh.

Image convention: pixel (x, y) has x to the right and y downwards from the
top-left corner; its ray passes through the pixel centre (x + 0.5, y + 0.5).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from . import _arrays, _core

InvalidInputError = _core.InvalidInputError


def _size(size, where="render") -> tuple:
    try:
        if isinstance(size, (str, bytes)):
            raise TypeError
        w, h = (int(s) for s in size)
        if (w, h) != tuple(size):  # 640.5 pixels, not silently 640
            raise ValueError
    except (TypeError, ValueError, OverflowError):
        raise InvalidInputError(f"{where}: size must be (width, height), got {size!r}") from None
    if w < 1 or h < 1 or w * h > 1 << 28:
        raise InvalidInputError(f"{where}: bad image size {w} x {h}")
    return w, h

def _unit(v):
    """v / |v| without squaring its coordinates (a scene 1e200 across), or None for 0."""
    big = float(np.max(np.abs(v)))
    if not big > 0 or not math.isfinite(big):
        return None
    v = v / big
    return v / np.linalg.norm(v)


@dataclass
class Camera:
    """A pinhole camera.

    Parameters
    ----------
    eye, target : (3,) float
        position and point looked at (world units).
    up : (3,) float
        up direction (default +z); must not be parallel to ``target - eye``.
    fov : float
        vertical field of view in degrees, in (0, 180).
    """
    eye: np.ndarray
    target: np.ndarray
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    fov: float = 40.0

    def __post_init__(self):
        self.eye = _arrays.vector3(self.eye, "Camera: eye")
        self.target = _arrays.vector3(self.target, "Camera: target")
        self.up = _arrays.vector3(self.up, "Camera: up")
        self.fov = float(self.fov)
        if not 0 < self.fov < 180:
            raise InvalidInputError(f"Camera: fov must be in (0, 180) degrees, got {self.fov}")
        f = _unit(self.target - self.eye)
        if f is None:
            raise InvalidInputError("Camera: eye and target coincide")
        up = _unit(self.up)
        if up is None or not np.linalg.norm(np.cross(f, up)) > 1e-12:
            raise InvalidInputError("Camera: up is zero or parallel to the viewing direction")

    @classmethod
    def look_at(cls, eye, target, up=(0.0, 0.0, 1.0), fov: float = 40.0) -> "Camera":
        return cls(eye, target, up, fov)

    @classmethod
    def framing(cls, mesh_or_bounds, direction=(1.0, -1.6, 0.9), up=(0.0, 0.0, 1.0), fov: float = 40.0,
                size=(800, 600), margin: float = 1.08) -> "Camera":
        """A camera looking at the centre of a bounding box from ``direction`` (from
        the target towards the eye), far enough that the box's bounding sphere fits
        the image of ``size`` with ``margin``.

        ``mesh_or_bounds``: a Mesh (or anything with vertices), an (n, 3) point
        array, or a (2, 3) [min, max] box."""
        if hasattr(mesh_or_bounds, "vertices"):
            pts = np.asarray(mesh_or_bounds.vertices, dtype=np.float64)
        else:
            pts = np.asarray(mesh_or_bounds, dtype=np.float64)
        if pts.ndim == 0 or pts.shape[-1] != 3:
            raise InvalidInputError(f"Camera.framing: expected (n, 3) points or a (2, 3) box, got shape {pts.shape}")
        pts = pts.reshape(-1, 3)
        fov = float(fov)
        if not 0 < fov < 180:
            raise InvalidInputError(f"Camera.framing: fov must be in (0, 180) degrees, got {fov}")
        margin = float(margin)
        if not (math.isfinite(margin) and margin > 0):
            raise InvalidInputError(f"Camera.framing: margin must be a positive number, got {margin}")
        if pts.shape[0] == 0 or not np.isfinite(pts).all():
            raise InvalidInputError("Camera.framing: no finite points to frame")
        lo, hi = _arrays.bounds(pts)
        centre = 0.5 * lo + 0.5 * hi
        # The half diagonal without squaring coordinates (a mesh 1e200 across has
        # a finite radius whose square is not).
        half = 0.5 * hi - 0.5 * lo
        big = float(np.max(np.abs(half)))
        radius = big * float(np.linalg.norm(half / big)) if big > 0 else 1.0
        d = _arrays.vector3(direction, "Camera.framing: direction")
        if not np.linalg.norm(d) > 0:
            raise InvalidInputError("Camera.framing: direction is zero")
        d = d / np.linalg.norm(d)
        w, h = _size(size, "Camera.framing")
        half_v = math.radians(fov) / 2
        half_h = math.atan(math.tan(half_v) * w / h)
        dist = margin * radius / math.sin(min(half_v, half_h))
        return cls(centre + dist * d, centre, up, fov)

    def _frame(self):
        """Forward, right and up unit vectors and tan(fov / 2)."""
        f = _unit(self.target - self.eye)
        r = _unit(np.cross(f, _unit(self.up)))
        return f, r, np.cross(r, f), math.tan(math.radians(self.fov) / 2)

    def ray(self, x, y, size=(800, 600)):
        """(origin, unit direction) of the ray through pixel (x, y) of an image of ``size``."""
        w, h = _size(size, "Camera.ray")
        x, y = float(x), float(y)
        if not (math.isfinite(x) and math.isfinite(y)):
            raise InvalidInputError(f"Camera.ray: pixel ({x}, {y}) is not finite")
        f, r, u, t = self._frame()
        sx = (2.0 * (x + 0.5) / w - 1.0) * t * w / h
        sy = (1.0 - 2.0 * (y + 0.5) / h) * t
        d = f + sx * r + sy * u
        return self.eye.copy(), d / np.linalg.norm(d)

    def project(self, points, size=(800, 600)) -> np.ndarray:
        """(n, 2) continuous pixel coordinates (x, y) of world points; a point at
        (x, y) lies in pixel (floor(x + 0.5), floor(y + 0.5)). NaN behind the camera."""
        w, h = _size(size, "Camera.project")
        P = np.atleast_2d(np.asarray(points, dtype=np.float64))
        if P.ndim != 2 or P.shape[1] != 3:
            raise InvalidInputError(f"Camera.project: expected (n, 3) points, got shape {np.shape(points)}")
        P = P - self.eye
        f, r, u, t = self._frame()
        z = P @ f
        with np.errstate(divide="ignore", invalid="ignore"):
            x = ((P @ r) / z / (t * w / h) + 1.0) * 0.5 * w - 0.5
            y = (1.0 - (P @ u) / z / t) * 0.5 * h - 0.5
        out = np.stack([x, y], axis=1)
        out[z <= 0] = np.nan
        return out
