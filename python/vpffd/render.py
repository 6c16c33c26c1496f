"""Picking and ray-cast rendering (Embree, Debian's libembree-dev), PNG files.

Image convention: pixel (x, y) has x to the right and y downwards from the
top-left corner; its ray passes through the pixel centre (x + 0.5, y + 0.5).
Images are (H, W, 3) uint8 arrays, top row first.
"""
from __future__ import annotations

import math
import struct
import zlib
from dataclasses import dataclass, field

import numpy as np

from . import _arrays, _core
from .mesh import Mesh

InvalidInputError = _core.InvalidInputError
BackendUnavailableError = _core.BackendUnavailableError


def _require_embree(where: str) -> None:
    if not _core.has_embree:
        raise BackendUnavailableError(f"{where}: this build of vpffd has no Embree (install libembree-dev and "
                                      "rebuild)")


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


# --- camera ---------------------------------------------------------------------
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
        f = self.target - self.eye
        if not np.linalg.norm(f) > 0:
            raise InvalidInputError("Camera: eye and target coincide")
        if not np.linalg.norm(np.cross(f, self.up)) > 1e-12 * np.linalg.norm(f) * np.linalg.norm(self.up):
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
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        centre = 0.5 * (lo + hi)
        radius = 0.5 * float(np.linalg.norm(hi - lo)) or 1.0
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
        f = self.target - self.eye
        f = f / np.linalg.norm(f)
        r = np.cross(f, self.up)
        r = r / np.linalg.norm(r)
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


# --- picking --------------------------------------------------------------------
@dataclass
class Hit:
    """The first surface point hit by a ray.

    Attributes
    ----------
    point : (3,) float64
        hit point on the mesh that was picked (world units).
    face : int
        index of the hit triangle.
    barycentric : (3,) float64
        weights of the face's three corners (sum 1): ``point == barycentric @ V[F[face]]``.
    distance : float
        distance from the ray origin along the (unit) ray direction.
    """
    point: np.ndarray
    face: int
    barycentric: np.ndarray
    distance: float

    @property
    def nearest_corner(self) -> int:
        """0, 1 or 2: the corner of ``face`` with the largest weight."""
        return int(np.argmax(self.barycentric))

    def rest_point(self, mesh) -> np.ndarray:
        """(3,) the same surface point on ``mesh`` (same faces, e.g. the rest mesh of
        a deformed one): usable as the source of a Deformer point constraint."""
        m = Mesh.from_any(mesh)
        if not 0 <= self.face < m.n_faces:
            raise InvalidInputError(f"Hit.rest_point: face {self.face} does not exist in a mesh of {m.n_faces} faces")
        return self.barycentric @ m.vertices[m.faces[self.face]]

    def lattice_parameter(self, lattice, mesh) -> np.ndarray:
        """(3,) exact parameter (u, v, w) of the hit in ``lattice`` (a vpffd.Lattice),
        through the rest point on ``mesh``: deforming it with any control points
        gives the hit's image."""
        return lattice.parameters(self.rest_point(mesh)[None, :])[0]


class Scene:
    """A mesh loaded once for many picks or renders (an Embree BVH).

    Parameters
    ----------
    mesh : Mesh, (vertices, faces) pair, or object with vertices/faces
    """

    def __init__(self, mesh):
        _require_embree("Scene")
        self.mesh = Mesh.from_any(mesh)
        self._s = _core.RayScene(self.mesh.vertices, self.mesh.faces)

    def pick_many(self, origins, directions):
        """Vectorised picking: (hit (n,) bool, face (n,) int64, barycentric (n, 3),
        distance (n,) with inf for misses, point (n, 3)); n may be 0."""
        # an empty list has shape (0,): no rays, as (0, 3)
        O, D = (np.zeros((0, 3)) if isinstance(a, (list, tuple)) and len(a) == 0 else a
                for a in (origins, directions))
        O = _arrays.points(O, "pick: origins", allow_empty=True)
        D = _arrays.points(D, "pick: directions", rows=O.shape[0], allow_empty=True)
        hit, face, uv, dist, point = self._s.intersect(O, D, 0.0)
        bary = np.column_stack([1.0 - uv[:, 0] - uv[:, 1], uv[:, 0], uv[:, 1]])
        return hit, face, bary, dist, point

    def pick(self, origin, direction):
        """The first hit of the ray origin + t * direction (t >= 0), or None."""
        o = _arrays.vector3(origin, "pick: origin")
        d = _arrays.vector3(direction, "pick: direction")
        if not np.linalg.norm(d) > 0:
            raise InvalidInputError("pick: direction is zero")
        hit, face, bary, dist, point = self.pick_many(o[None, :], d[None, :])
        if not hit[0]:
            return None
        return Hit(point=point[0], face=int(face[0]), barycentric=bary[0], distance=float(dist[0]))

    def pick_pixel(self, camera: Camera, x, y, size=(800, 600)):
        """The first hit under pixel (x, y) of an image of ``size`` seen by ``camera``, or None."""
        if not isinstance(camera, Camera):
            raise TypeError(f"pick_pixel: expected a vpffd.Camera, got {type(camera).__name__}")
        o, d = camera.ray(x, y, size)
        return self.pick(o, d)


def pick(mesh, origin, direction):
    """The first hit of the ray ``origin + t * direction`` (t >= 0) on ``mesh``.

    Parameters
    ----------
    mesh : Mesh, (vertices, faces) pair, or object with vertices/faces
    origin, direction : (3,) float (direction need not be unit length)

    Returns
    -------
    Hit (point, face, barycentric, distance) or None when the ray misses.
    For many rays on one mesh, build a ``Scene`` once.
    """
    return Scene(mesh).pick(origin, direction)


def pick_pixel(mesh, camera: Camera, x, y, size=(800, 600)):
    """The first hit under pixel (x, y) of a ``size`` image from ``camera``, or None
    (same rays as ``render``)."""
    return Scene(mesh).pick_pixel(camera, x, y, size)


# --- colours --------------------------------------------------------------------
# Anchors of two colour maps (sRGB in [0, 1]), interpolated linearly.
_VIRIDIS = np.array([[0.267, 0.005, 0.329], [0.283, 0.141, 0.458], [0.254, 0.265, 0.530], [0.207, 0.372, 0.553],
                     [0.164, 0.471, 0.558], [0.128, 0.567, 0.551], [0.135, 0.659, 0.518], [0.267, 0.749, 0.441],
                     [0.478, 0.821, 0.318], [0.741, 0.873, 0.150], [0.993, 0.906, 0.144]])
_COOLWARM = np.array([[0.230, 0.299, 0.754], [0.400, 0.533, 0.934], [0.602, 0.731, 0.999], [0.788, 0.845, 0.939],
                      [0.867, 0.867, 0.867], [0.957, 0.770, 0.679], [0.968, 0.608, 0.480], [0.887, 0.392, 0.310],
                      [0.706, 0.016, 0.150]])
COLORMAPS = {"viridis": _VIRIDIS, "coolwarm": _COOLWARM}


def colormap(values, cmap=None, vmin=None, vmax=None) -> np.ndarray:
    """(n, 3) float colours of (n,) scalars.

    Default: "coolwarm" centred on 0 (symmetric range) when the values have both
    signs, as a local volume change has; else "viridis" over [min, max]."""
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    if not np.isfinite(v).all():
        raise InvalidInputError("colormap: values contain NaN or Inf")
    if v.size == 0:
        return np.zeros((0, 3))
    for nm, x in (("vmin", vmin), ("vmax", vmax)):
        if x is not None and not math.isfinite(float(x)):
            raise InvalidInputError(f"colormap: {nm} must be a finite number, got {x!r}")
    if vmin is not None and vmax is not None and float(vmin) > float(vmax):
        raise InvalidInputError(f"colormap: vmin {vmin!r} is above vmax {vmax!r}")
    signed = v.min() < 0 < v.max()
    if cmap is None:
        cmap = "coolwarm" if signed else "viridis"
    if cmap not in COLORMAPS:
        raise InvalidInputError(f"colormap: unknown colour map {cmap!r}; known: {', '.join(COLORMAPS)}")
    if vmin is None and vmax is None and signed and cmap == "coolwarm":
        a = float(np.abs(v).max())
        vmin, vmax = -a, a
    lo = float(v.min()) if vmin is None else float(vmin)
    hi = float(v.max()) if vmax is None else float(vmax)
    t = np.zeros_like(v) if not hi > lo else np.clip((v - lo) / (hi - lo), 0.0, 1.0)
    table = COLORMAPS[cmap]
    s = t * (len(table) - 1)
    i = np.minimum(s.astype(int), len(table) - 2)
    w = (s - i)[:, None]
    return (1 - w) * table[i] + w * table[i + 1]


def _vertex_colors(colors, n, cmap, vmin, vmax):
    if colors is None:
        return None
    c = np.asarray(colors)
    if c.ndim == 1:
        if c.shape[0] != n:
            raise InvalidInputError(f"render: {c.shape[0]} colour values for {n} vertices")
        return colormap(c, cmap, vmin, vmax)
    if c.ndim == 2 and c.shape == (n, 3):
        return _rgb(c, _arrays.points(c, "render: colors"), "colors")
    raise InvalidInputError(f"render: colors must be (V,) values or (V, 3) RGB for V={n}, got shape {c.shape}")


def lattice_lines(shape) -> np.ndarray:
    """(m, 2) int32 index pairs joining neighbouring control points of a lattice of
    ``shape`` (nu, nv, nw), indices into ``control_points.reshape(-1, 3)``."""
    nu, nv, nw = (int(s) for s in shape)
    idx = np.arange(nu * nv * nw).reshape(nu, nv, nw)
    pairs = [np.stack([idx[:-1].ravel(), idx[1:].ravel()], 1),
             np.stack([idx[:, :-1].ravel(), idx[:, 1:].ravel()], 1),
             np.stack([idx[:, :, :-1].ravel(), idx[:, :, 1:].ravel()], 1)]
    return np.ascontiguousarray(np.concatenate(pairs), dtype=np.int32)


def _rgb(raw, a, name):
    """RGB in [0, 1] from ``a`` (float64, validated) of the array ``raw`` given
    by the caller. The dtype decides the scale, never the values: integers
    (uint8, any int type, Python ints) are 0-255, floats are 0-1; values
    outside the scale raise rather than being rescaled or clipped."""
    if np.issubdtype(np.asarray(raw).dtype, np.integer):
        if a.size and not (a.min() >= 0 and a.max() <= 255):
            raise InvalidInputError(f"render: {name}: integer colours are 0-255, got values from {a.min():g} "
                                    f"to {a.max():g}")
        if np.asarray(raw).dtype != np.uint8 and a.size and a.max() == 1:
            # (1, 1, 1) meant as white would be almost black: refuse the guess
            raise InvalidInputError(f"render: {name}: integer colours are 0-255, so {raw!r} would be almost "
                                    f"black; write 1.0 for a colour in [0, 1] or 255 for 0-255"
                                    if np.ndim(raw) == 1 else
                                    f"render: {name}: integer colours are 0-255, and these are all 0 or 1 "
                                    f"(almost black); pass floats for colours in [0, 1] or uint8 for 0-255")
        return a / 255.0
    if a.size and not (a.min() >= 0.0 and a.max() <= 1.0):
        raise InvalidInputError(f"render: {name}: float colours are in [0, 1] (integers are 0-255), got values "
                                f"from {a.min():g} to {a.max():g}")
    return a


def _color3(c, name):
    return _rgb(c, _arrays.vector3(c, f"render: {name}"), name)


# --- rendering ------------------------------------------------------------------
def render(mesh, camera=None, lattice=None, size=(800, 600), colors=None, control_points=None, *,
           background=(1.0, 1.0, 1.0), base_color=(0.72, 0.74, 0.78), samples: int = 1, normals=None,
           cmap=None, vmin=None, vmax=None, lines: bool = True, points: bool = True, point_radius: float = 3.0,
           line_color=(0.85, 0.25, 0.15), point_color=(0.1, 0.2, 0.8), hidden_alpha: float = 0.25,
           return_depth: bool = False):
    """Ray-cast image of a mesh with smooth shading, optionally with a lattice.

    Parameters
    ----------
    mesh : Mesh, (vertices, faces) pair, or object with vertices/faces
        e.g. a deformed mesh ``Mesh(result.vertices, mesh.faces)``.
    camera : Camera, optional
        default: ``Camera.framing`` of the mesh (and of the lattice, when drawn).
    lattice : vpffd.Lattice, optional
        draws its ``control_points`` (or the ``control_points`` argument) as points joined by lines.
    size : (width, height)
    colors : (V, 3) RGB, or (V,) scalars, optional
        per-vertex colours, interpolated over the faces; scalars go through
        ``colormap(values, cmap, vmin, vmax)`` (e.g. the local volume change).
        RGB colours (this and the ``*_color`` and ``background`` arguments)
        are read by dtype: floats in [0, 1], integers (uint8 or any int
        type, Python ints included) in 0-255; values outside the range raise
        InvalidInputError. So ``(1.0, 1.0, 1.0)`` and ``(255, 255, 255)`` are
        white; integer colours of only 0s and 1s such as ``(1, 1, 1)`` are
        refused as ambiguous.
    control_points : (nu, nv, nw, 3), optional
        control points to draw instead of ``lattice.control_points``.
    background, base_color : RGB, floats in [0, 1] or integers in 0-255
    samples : int
        supersampling per axis (1..8); 2 gives smoother edges at 4x the cost.
    normals : (V, 3), optional
        shading normals (default: area-weighted vertex normals of the mesh).
    lines, points : bool
        draw the lattice's lines / control points.
    line_color, point_color : RGB, floats in [0, 1] or integers in 0-255
    hidden_alpha : float
        opacity of lattice parts hidden behind the surface.
    return_depth : bool
        also return the (H, W) float32 distance from the eye (inf on the background).

    Returns
    -------
    (H, W, 3) uint8 image (and the depth map with ``return_depth``).
    """
    _require_embree("render")
    m = Mesh.from_any(mesh)
    w, h = _size(size)
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or not 1 <= samples <= 8:
        raise InvalidInputError(f"render: samples must be an integer in 1..8, got {samples!r}")
    r_max = max(w, h, 8)  # the C++ loop covers (2 r)^2 pixels per control point
    if not (math.isfinite(float(point_radius)) and 0 <= float(point_radius) <= r_max):
        raise InvalidInputError(f"render: point_radius must be in 0..{r_max} pixels, got {point_radius!r}")
    if not 0 <= float(hidden_alpha) <= 1:
        raise InvalidInputError(f"render: hidden_alpha must be in [0, 1], got {hidden_alpha!r}")
    cp = None
    if control_points is not None:
        cp = np.asarray(control_points, dtype=np.float64)
    elif lattice is not None:
        if not hasattr(lattice, "control_points"):
            raise TypeError(f"render: lattice must be a vpffd.Lattice, got {type(lattice).__name__}")
        cp = np.asarray(lattice.control_points, dtype=np.float64)
    if cp is not None and (cp.ndim != 4 or cp.shape[3] != 3):
        raise InvalidInputError(f"render: control_points must have shape (nu, nv, nw, 3), got {cp.shape}")
    if cp is not None and not np.isfinite(cp).all():
        raise InvalidInputError("render: control points contain NaN or Inf")
    if camera is None:
        pts = m.vertices if cp is None else np.concatenate([m.vertices, cp.reshape(-1, 3)])
        camera = Camera.framing(pts, size=(w, h))
    elif not isinstance(camera, Camera):
        raise TypeError(f"render: camera must be a vpffd.Camera or None, got {type(camera).__name__}")
    vc = _vertex_colors(colors, m.n_vertices, cmap, vmin, vmax)
    N = None if normals is None else _arrays.points(normals, "render: normals", rows=m.n_vertices)
    P = L = None
    if cp is not None:
        P = np.ascontiguousarray(cp.reshape(-1, 3))
        L = lattice_lines(cp.shape[:3]) if lines else np.zeros((0, 2), np.int32)
    scene = _core.RayScene(m.vertices, m.faces)
    image, depth = scene.render(camera.eye, camera.target, camera.up, camera.fov, w, h, int(samples),
                                _color3(background, "background"), _color3(base_color, "base_color"), vc, N, P, L,
                                _color3(line_color, "line_color"), _color3(point_color, "point_color"),
                                float(point_radius) if points else 0.0, float(hidden_alpha))
    return (image, depth) if return_depth else image


# --- PNG ------------------------------------------------------------------------
def save_png(path, image) -> None:
    """Writes an (H, W, 3) or (H, W, 4) uint8 image (or (H, W) grey) as a PNG file
    (zlib + struct; no imaging library needed). Float images in [0, 1] are scaled."""
    import os
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"save_png: expected a file name, got {type(path).__name__}")
    img = np.asarray(image)
    if img.dtype != np.uint8:
        if not np.issubdtype(img.dtype, np.floating):
            raise TypeError(f"save_png: expected uint8 or float in [0, 1], got dtype {img.dtype}")
        img = (np.clip(np.nan_to_num(img), 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    if img.ndim == 2:
        img = img[:, :, None]
    if img.ndim != 3 or img.shape[2] not in (1, 3, 4) or img.shape[0] < 1 or img.shape[1] < 1:
        raise InvalidInputError(f"save_png: expected (H, W), (H, W, 3) or (H, W, 4), got shape {np.shape(image)}")
    h, w, c = img.shape
    color_type = {1: 0, 3: 2, 4: 6}[c]
    raw = np.concatenate([np.zeros((h, 1), np.uint8), np.ascontiguousarray(img).reshape(h, w * c)], axis=1)

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, color_type, 0, 0, 0)) +
           chunk(b"IDAT", zlib.compress(raw.tobytes(), 6)) + chunk(b"IEND", b""))
    try:
        with open(path, "wb") as f:
            f.write(png)
    except OSError as e:
        raise _core.MeshIOError(f"save_png: '{os.fspath(path)}': {e.strerror or e}") from None


def load_png(path) -> np.ndarray:
    """Reads an 8-bit, non-interlaced grey/RGB/RGBA PNG (as save_png writes) into an
    (H, W, C) uint8 array."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise _core.MeshIOError(f"load_png: '{path}': not a PNG file")
    pos, idat, hdr = 8, [], None
    while pos + 8 <= len(data):
        n, tag = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if tag == b"IHDR":
            hdr = struct.unpack(">IIBBBBB", body)
        elif tag == b"IDAT":
            idat.append(body)
        elif tag == b"IEND":
            break
        pos += 12 + n
    if hdr is None:
        raise _core.MeshIOError(f"load_png: '{path}': no IHDR chunk")
    w, h, depth, ctype, _, _, interlace = hdr
    if depth != 8 or interlace or ctype not in (0, 2, 6):
        raise _core.MeshIOError(f"load_png: '{path}': only 8-bit non-interlaced grey/RGB/RGBA is supported")
    c = {0: 1, 2: 3, 6: 4}[ctype]
    try:
        raw = np.frombuffer(zlib.decompress(b"".join(idat)), np.uint8).reshape(h, 1 + w * c)
    except (zlib.error, ValueError):
        raise _core.MeshIOError(f"load_png: '{path}': truncated or corrupt image data") from None
    out = np.zeros((h, w * c), np.int32)
    for y in range(h):
        ft, line = raw[y, 0], raw[y, 1:].astype(np.int32)
        prev = out[y - 1] if y else np.zeros(w * c, np.int32)
        if ft == 0:
            cur = line
        elif ft == 2:
            cur = (line + prev) & 255
        else:  # Sub, Average, Paeth need the left neighbour: per pixel
            cur = np.zeros(w * c, np.int32)
            for i in range(w * c):
                a = cur[i - c] if i >= c else 0
                b = prev[i]
                cc = prev[i - c] if i >= c else 0
                if ft == 1:
                    pred = a
                elif ft == 3:
                    pred = (a + b) // 2
                else:
                    p = a + b - cc
                    pa, pb, pc = abs(p - a), abs(p - b), abs(p - cc)
                    pred = a if pa <= pb and pa <= pc else (b if pb <= pc else cc)
                cur[i] = (line[i] + pred) & 255
        out[y] = cur
    return out.astype(np.uint8).reshape(h, w, c)
