"""Ray-cast rendering with Embree (Debian's libembree-dev): smooth shading,
per-vertex colours, a lattice overlay. Images are (H, W, 3) uint8 arrays, top
row first (see vpffd.camera for the pixel convention).

The module is ``vpffd.rendering``; its main function is ``vpffd.render``.
"""
from __future__ import annotations

import math

import numpy as np

from . import _arrays, _core
from .camera import Camera, _size
from .colormap import FOLD_COLOR, colormap
from .mesh import Mesh
from .picking import Scene, _require_embree

InvalidInputError = _core.InvalidInputError


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


# Vertices in cells the fold check could not decide: amber, between "fine" and "folded".
UNDECIDED_COLOR = np.array([0.95, 0.68, 0.10])


def _fold_status(folds, rest_vertices, n):
    """(V,) status per vertex (-1 folded, 0 undecided, 1 certified) from a FoldReport
    and the rest positions of the vertices, or from a status array given directly."""
    if hasattr(folds, "status_at"):
        if rest_vertices is None:
            raise InvalidInputError("render: folds=<FoldReport> needs rest_vertices, the rest positions of the "
                                    "mesh's vertices (the report's cells are in rest space)")
        X = _arrays.points(rest_vertices, "render: rest_vertices", rows=n)
        return np.asarray(folds.status_at(X))
    st = np.asarray(folds)
    if st.shape != (n,) or not np.issubdtype(st.dtype, np.integer):
        raise InvalidInputError(f"render: folds must be a FoldReport or a (V,) integer status array for V={n}, "
                                f"got {type(folds).__name__} {getattr(st, 'shape', '')}")
    return st


def lattice_lines(shape) -> np.ndarray:
    """(m, 2) int32 index pairs joining neighbouring control points of a lattice of
    ``shape`` (nu, nv, nw), indices into ``control_points.reshape(-1, 3)``."""
    nu, nv, nw = (int(s) for s in shape)
    idx = np.arange(nu * nv * nw).reshape(nu, nv, nw)
    pairs = [np.stack([idx[:-1].ravel(), idx[1:].ravel()], 1),
             np.stack([idx[:, :-1].ravel(), idx[:, 1:].ravel()], 1),
             np.stack([idx[:, :, :-1].ravel(), idx[:, :, 1:].ravel()], 1)]
    return np.ascontiguousarray(np.concatenate(pairs), dtype=np.int32)


def _net(net, name):
    """(points (n, 3) float64, edges (m, 2) int32) of a control net, checked."""
    if not (isinstance(net, (tuple, list)) and len(net) == 2):
        raise TypeError(f"{name}: expected a (points, edges) pair, got {type(net).__name__}")
    P = _arrays.points(net[0], f"{name} points")
    E = np.asarray(net[1])
    if E.ndim != 2 or E.shape[1] != 2 or not np.issubdtype(E.dtype, np.integer):
        raise InvalidInputError(f"{name} edges: expected an (m, 2) integer array, got {E.dtype} of shape {E.shape}")
    if E.size and (E.min() < 0 or E.max() >= len(P)):
        raise InvalidInputError(f"{name} edges: indices must be in [0, {len(P)}), got {int(E.min())}..{int(E.max())}")
    return P, np.ascontiguousarray(E, dtype=np.int32)


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

def render(mesh, camera=None, lattice=None, size=(800, 600), colors=None, control_points=None, *,
           background=(1.0, 1.0, 1.0), base_color=(0.72, 0.74, 0.78), samples: int = 1, normals=None,
           cmap=None, vmin=None, vmax=None, lines: bool = True, points: bool = True, point_radius: float = 3.0,
           line_color=(0.85, 0.25, 0.15), point_color=(0.1, 0.2, 0.8), hidden_alpha: float = 0.25,
           line_alpha: float = 1.0, line_width: float = 1.0, adaptive: bool = True, return_depth: bool = False,
           folds=None, rest_vertices=None, net=None):
    """Ray-cast image of a mesh with smooth shading, optionally with a lattice.

    Parameters
    ----------
    mesh : Mesh, (vertices, faces) pair, object with vertices/faces, or vpffd.Scene
        e.g. a deformed mesh ``Mesh(result.vertices, mesh.faces)``; a Scene
        draws its mesh with the BVH it holds (no build: e.g. the frames of a
        deformation through one ``Scene(mesh, refit=True)`` and ``set_vertices``).
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
        anti-aliasing: rays per pixel per axis (1..8), S x S in the pixels next to
        an edge (silhouette, depth or colour step) and one elsewhere.
    adaptive : bool
        False: S x S rays in every pixel (S^2 times the cost of samples=1).
    normals : (V, 3), optional
        shading normals (default: area-weighted vertex normals of the mesh).
    lines, points : bool
        draw the lattice's lines / control points.
    line_color, point_color : RGB, floats in [0, 1] or integers in 0-255
    hidden_alpha : float
        opacity of lattice parts hidden behind the surface (times ``line_alpha`` for lines).
    line_alpha : float
        opacity of the visible lattice lines, in [0, 1].
    line_width : float
        width of the lattice lines in pixels (anti-aliased), in (0, 64].
    return_depth : bool
        also return the (H, W) float32 distance from the eye (inf on the background).
    folds : FoldReport or (V,) int, optional
        marks the vertices in folded lattice cells in the fold colour (green) and
        those in undecided cells in amber, over ``colors``: a ``vpffd.check_folds``
        report with ``rest_vertices`` (V, 3), the rest positions of the mesh's
        vertices, or the status per vertex (-1, 0, 1) of ``vpffd.folds.vertex_folds``.
    net : (points (n, 3), edges (m, 2) int), optional
        a control mesh drawn as points joined by lines, like a lattice (the
        ``lines``, ``points`` and colour arguments apply), e.g. a subdivision
        surface's control net; not with ``lattice`` or ``control_points``.

    Returns
    -------
    (H, W, 3) uint8 image (and the depth map with ``return_depth``).
    """
    _require_embree("render")
    scene = mesh if isinstance(mesh, Scene) else None
    m = scene.mesh if scene is not None else Mesh.from_any(mesh)
    w, h = _size(size)
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or not 1 <= samples <= 8:
        raise InvalidInputError(f"render: samples must be an integer in 1..8, got {samples!r}")
    r_max = max(w, h, 8)  # the C++ loop covers (2 r)^2 pixels per control point
    if not (math.isfinite(float(point_radius)) and 0 <= float(point_radius) <= r_max):
        raise InvalidInputError(f"render: point_radius must be in 0..{r_max} pixels, got {point_radius!r}")
    for name, x, lo, hi in (("hidden_alpha", hidden_alpha, 0, 1), ("line_alpha", line_alpha, 0, 1)):
        if not lo <= float(x) <= hi:
            raise InvalidInputError(f"render: {name} must be in [{lo}, {hi}], got {x!r}")
    if not 0 < float(line_width) <= 64:
        raise InvalidInputError(f"render: line_width must be in (0, 64] pixels, got {line_width!r}")
    cp = None
    if net is not None:
        if lattice is not None or control_points is not None:
            raise InvalidInputError("render: give net or a lattice (control_points), not both")
        net_points, net_edges = _net(net, "render: net")
    elif control_points is not None:
        cp = np.asarray(control_points, dtype=np.float64)
    elif lattice is not None:
        if not hasattr(lattice, "control_points"):
            raise TypeError(f"render: lattice must be a vpffd.Lattice, got {type(lattice).__name__}")
        cp = np.asarray(lattice.control_points, dtype=np.float64)
    if cp is not None and getattr(lattice, "periodic", "") and cp.shape[:3] == tuple(lattice.shape):
        cp = lattice.expanded_control_points(cp)  # draw the tied copies too: the net closes
    if cp is not None and (cp.ndim != 4 or cp.shape[3] != 3):
        raise InvalidInputError(f"render: control_points must have shape (nu, nv, nw, 3), got {cp.shape}")
    if cp is not None and not np.isfinite(cp).all():
        raise InvalidInputError("render: control points contain NaN or Inf")
    if net is not None:
        cp = net_points  # framed and drawn as the lattice's points are
    if camera is None:
        pts = m.vertices if cp is None else np.concatenate([m.vertices, cp.reshape(-1, 3)])
        camera = Camera.framing(pts, size=(w, h))
    elif not isinstance(camera, Camera):
        raise TypeError(f"render: camera must be a vpffd.Camera or None, got {type(camera).__name__}")
    vc = _vertex_colors(colors, m.n_vertices, cmap, vmin, vmax)
    if folds is not None:
        st = _fold_status(folds, rest_vertices, m.n_vertices)
        if vc is None:
            vc = np.tile(_color3(base_color, "base_color"), (m.n_vertices, 1))
        vc = np.array(vc, dtype=np.float64)
        vc[st == 0] = UNDECIDED_COLOR
        vc[st < 0] = FOLD_COLOR
    N = None if normals is None else _arrays.points(normals, "render: normals", rows=m.n_vertices)
    P = L = None
    if cp is not None:
        P = np.ascontiguousarray(cp.reshape(-1, 3))
        edges = net_edges if net is not None else lattice_lines(cp.shape[:3])
        L = edges if lines else np.zeros((0, 2), np.int32)
    # One image: a quick BVH build pays more than a better one.
    rs = scene._s if scene is not None else _core.RayScene(m.vertices, m.faces, True)
    image, depth = rs.render(camera.eye, camera.target, camera.up, camera.fov, w, h, int(samples),
                                _color3(background, "background"), _color3(base_color, "base_color"), vc, N, P, L,
                                _color3(line_color, "line_color"), _color3(point_color, "point_color"),
                                float(point_radius) if points else 0.0, float(hidden_alpha), float(line_alpha),
                                float(line_width), bool(adaptive))
    return (image, depth) if return_depth else image
