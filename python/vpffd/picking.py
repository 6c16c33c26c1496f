"""Picking: the first surface point hit by a ray (Embree finds the face, the hit
is recomputed in double precision against the double triangle)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _arrays, _core
from .camera import Camera
from .mesh import Mesh

InvalidInputError = _core.InvalidInputError
BackendUnavailableError = _core.BackendUnavailableError


def _require_embree(where: str) -> None:
    if not _core.has_embree:
        raise BackendUnavailableError(f"{where}: this build of vpffd has no Embree (install libembree-dev and "
                                      "rebuild)")

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
        weights of the face's three corners, each in [0, 1], sum 1 (up to one
        rounding): ``point == barycentric @ V[F[face]]``.
    distance : float
        distance from the ray origin along the (unit) ray direction.

    Embree (float32) chooses the face; point, distance and barycentrics are
    recomputed in double against the double triangle. Where the double ray
    passes just outside the face Embree chose (within float32 error of an edge,
    the true hit being on the neighbour), the point is snapped to that edge.
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
    refit : bool
        the mesh will move (``set_vertices``, e.g. the frames of a deformation):
        the BVH is built once and refitted to each new position, about 1/15 of
        a rebuild (measured on 1.3 M triangles); a refitted BVH stays correct
        but its rays slow down the further the mesh moves from where it was
        built.

    Notes
    -----
    ``vpffd.render(scene, ...)`` draws the scene's mesh with its BVH.
    """

    def __init__(self, mesh, *, refit: bool = False):
        _require_embree("Scene")
        self.mesh = Mesh.from_any(mesh)
        self._s = _core.RayScene(self.mesh.vertices, self.mesh.faces, False, bool(refit))

    def set_vertices(self, vertices) -> None:
        """Moves the mesh's vertices to ``vertices`` (V, 3), same count and faces;
        picks and renders then see the moved mesh (as a Scene built from it
        would). Refits the BVH of a ``refit=True`` scene, else rebuilds it."""
        V = _arrays.points(vertices, "Scene.set_vertices: vertices", rows=self.mesh.n_vertices)  # a copy
        self._s.set_vertices(V)
        self.mesh = self.mesh._with_vertices(V)

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
        if not np.abs(d).max() > 0:  # (a norm underflows for 1e-300)
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

    Any finite mesh and ray work (the scene is normalised to a unit box
    internally); InvalidInputError only for an origin so far away (about 1e23
    mesh sizes, for a ray not along an axis) that double precision cannot place
    the ray near the mesh to float32 accuracy.
    """
    return Scene(mesh).pick(origin, direction)


def pick_pixel(mesh, camera: Camera, x, y, size=(800, 600)):
    """The first hit under pixel (x, y) of a ``size`` image from ``camera``, or None
    (same rays as ``render``)."""
    return Scene(mesh).pick_pixel(camera, x, y, size)
