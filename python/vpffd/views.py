"""The model's up axis and the camera's direction, one rule for the command line,
the pictures and Python code.

A model's up axis is guessed once (``guess_up_axis``: a flat base, else the file
format's convention, else z); a view (``parse_view``) is a named side or azimuth
and elevation in degrees, measured in the model's frame: up, front and right.
"""
from __future__ import annotations

import math

import numpy as np

from . import _arrays, _core
from .mesh import Mesh

InvalidInputError = _core.InvalidInputError

AXES = "xyz"

# The model's front, the direction towards a viewer facing it: -y for z up (the
# front of a z-up model), +z for y up (OpenGL's), -z for x up. Right is up x front.
_FRONT = {"z": (0.0, -1.0, 0.0), "y": (0.0, 0.0, 1.0), "x": (0.0, 0.0, -1.0)}
# The default three-quarter view from the front, right and above: 1.6 front, 1.0
# right, 0.9 up (azimuth 32 degrees, elevation 25.5).
DEFAULT_VIEW = (math.degrees(math.atan2(1.0, 1.6)), math.degrees(math.atan2(0.9, math.hypot(1.6, 1.0))))
#: named views: (azimuth, elevation) in degrees
NAMED_VIEWS = {"front": (0.0, 0.0), "back": (180.0, 0.0), "left": (-90.0, 0.0), "right": (90.0, 0.0),
               "top": (0.0, 90.0), "bottom": (0.0, -90.0), "default": DEFAULT_VIEW}

# Formats whose files are y-up by convention (scanners, Stanford PLY, OBJ from
# modelling tools, glTF) and z-up (3D printing, CAD).
_Y_UP_FORMATS = ("ply", "obj", "off", "om", "gltf", "glb")
_Z_UP_FORMATS = ("stl", "3mf", "amf")



def _axis_index(up) -> int:
    if isinstance(up, str) and up.lower() in ("x", "y", "z"):
        return AXES.index(up.lower())
    raise InvalidInputError(f"up: expected 'x', 'y' or 'z', got {up!r}")


def guess_up_axis(mesh, path=None) -> tuple:
    """(axis, reason): the model's up axis, "x", "y" or "z", and why.

    1. A standing model has a flat base: faces facing down along the axis, at
       its lowest end. The axis whose end (either one) carries the largest such
       area (at least 1 % of the surface, 1.5 times the runner-up) is up.
    2. Otherwise the file's convention, from ``path``'s extension: scans and
       modelling formats (PLY, OBJ, OFF, glTF) are y-up, 3D-printing formats
       (STL, 3MF) z-up.
    3. Otherwise z, vpffd's own convention.

    The command line (``vpffd deform``, ``vpffd subdiv``) and the pictures
    (``render_comparison`` and friends, ``up=None``) take their up axis from here.
    ``path`` defaults to the file a Mesh was read from (``load_mesh``), so a mesh
    loaded in Python gets the axis the command line gets for the same file. The
    edits (``vpffd.squash`` etc.) are plain functions of control points: their
    ``axis`` defaults to "z"; pass ``guess_up_axis(mesh)[0]`` to edit along the
    model's up axis as the command line does.
    """
    m = Mesh.from_any(mesh)
    if path is None:
        path = getattr(m, "_source", None)
    V, F = m.vertices, m.faces
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    n = np.cross(b - a, c - a)  # twice the area, along the normal
    area2 = np.linalg.norm(n, axis=1)
    total = float(area2.sum())
    lo, hi = _arrays.bounds(V)
    ext = hi - lo
    scores = []
    if total > 0 and ext.max() > 0:
        cen = (a + b + c) / 3.0
        with np.errstate(invalid="ignore", divide="ignore"):
            unit = n / area2[:, None]
        cos_flat = math.cos(math.radians(12))
        for k in range(3):
            if ext[k] <= 0:
                continue
            near = 0.02 * ext[k]
            for end, sign in ((lo[k], -1.0), (hi[k], 1.0)):
                # the base faces outwards at its end; either winding counts
                flat = (np.abs(unit[:, k]) > cos_flat) & (np.abs(cen[:, k] - end) <= near)
                scores.append((float(area2[flat].sum()) / total, k, "lowest" if sign < 0 else "highest"))
    scores.sort(reverse=True)
    if scores and scores[0][0] >= 0.01:
        best, runner = scores[0], next((s for s in scores[1:] if s[1] != scores[0][1]), (0.0, -1, ""))
        if best[0] >= 1.5 * runner[0]:
            return AXES[best[1]], (f"flat base of {100 * best[0]:.1f} % of the surface at the {best[2]} "
                                   f"{AXES[best[1]]}")
    if path is not None:
        import os
        name = os.path.basename(os.fsdecode(path)).lower()
        if name.endswith(".gz"):
            name = name[:-3]
        ext_name = name.rsplit(".", 1)[-1] if "." in name else ""
        if ext_name in _Y_UP_FORMATS:
            return "y", f".{ext_name} files are y-up by convention"
        if ext_name in _Z_UP_FORMATS:
            return "z", f".{ext_name} files are z-up by convention"
    return "z", "no flat base and no file convention: vpffd's default"


def parse_view(view) -> tuple:
    """(azimuth, elevation) in degrees from a view: None (the default three-quarter
    view), a name ("front", "back", "left", "right", "top", "bottom", "default"),
    a pair of numbers, or the text "AZ,EL" (e.g. "30,20"). Azimuth turns round the
    up axis from the front (0) towards the model's right (90); elevation is above
    the horizon (90 looks straight down), within [-90, 90]."""
    if view is None:
        return DEFAULT_VIEW
    if isinstance(view, str):
        key = view.strip().lower()
        if key in NAMED_VIEWS:
            return NAMED_VIEWS[key]
        parts = key.split(",")
        try:
            pair = tuple(float(p) for p in parts)
        except ValueError:
            pair = ()
        if len(pair) != 2:
            raise InvalidInputError(f"view: expected one of {', '.join(NAMED_VIEWS)} or AZIMUTH,ELEVATION in "
                                    f"degrees such as 30,20, got {view!r}")
        view = pair
    try:
        az, el = (float(v) for v in view)
    except (TypeError, ValueError):
        raise InvalidInputError(f"view: expected a name or (azimuth, elevation) in degrees, got {view!r}") from None
    if not (math.isfinite(az) and math.isfinite(el) and -90.0 <= el <= 90.0):
        raise InvalidInputError(f"view: azimuth must be finite and elevation in [-90, 90] degrees, got {az}, {el}")
    return az, el


def model_frame(up="z") -> tuple:
    """(front, right, up) unit vectors (3,) of a model whose up axis is ``up``."""
    k = _axis_index(up)
    u = np.zeros(3)
    u[k] = 1.0
    f = np.array(_FRONT[AXES[k]])
    return f, np.cross(u, f), u


def view_direction(up="z", view=None) -> np.ndarray:
    """(3,) unit direction from the target towards the eye for ``view``
    (``parse_view``; default the three-quarter view from the front, right and
    above) of a model whose up axis is ``up``."""
    az, el = (math.radians(a) for a in parse_view(view))
    f, r, u = model_frame(up)
    d = math.cos(el) * (math.cos(az) * f + math.sin(az) * r) + math.sin(el) * u
    return d / np.linalg.norm(d)
