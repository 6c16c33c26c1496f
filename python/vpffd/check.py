"""Defect report of a triangle mesh (``Mesh.check()``, ``vpffd info MESH``)."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from . import _core


@dataclass(frozen=True)
class MeshCheck:
    """Counts of everything that keeps a mesh from bounding a volume.

    All counts are taken on the faces exactly as stored (no vertex merging).

    Attributes
    ----------
    vertices, faces, edges : int
        sizes (``edges``: distinct undirected edges).
    boundary_edges : int
        edges with one face (holes, open borders).
    boundary_loops : int
        connected pieces of the boundary-edge graph (about one per hole).
    nonmanifold_edges : int
        edges with more than two faces.
    nonmanifold_vertices : int
        vertices whose faces form more than one fan (pinch points, bow ties).
    misoriented_edges : int
        edges whose two faces run along it in the same direction (inconsistent
        winding).
    degenerate_faces : int
        zero-area faces (repeated index, coincident or collinear corners).
    duplicate_vertices : int
        vertices at exactly the position of an earlier vertex (unwelded seams).
    duplicate_faces : int
        faces with the same three vertices as an earlier face.
    unreferenced_vertices : int
        vertices that no face uses.
    components : int
        groups of faces joined across edges with exactly two faces.
    euler_characteristic : int
        referenced vertices - edges + faces (2 for a sphere).
    signed_volume : float
        enclosed volume when closed and consistently oriented, else NaN.
    """
    vertices: int
    faces: int
    edges: int
    boundary_edges: int
    boundary_loops: int
    nonmanifold_edges: int
    nonmanifold_vertices: int
    misoriented_edges: int
    degenerate_faces: int
    duplicate_vertices: int
    duplicate_faces: int
    unreferenced_vertices: int
    components: int
    euler_characteristic: int
    signed_volume: float

    @classmethod
    def of(cls, vertices, faces) -> "MeshCheck":
        """Runs the checks on (V, 3) float64 vertices and (F, 3) int32 faces."""
        return cls(**_core.check_mesh(vertices, faces))

    # --- verdicts --------------------------------------------------------------
    @property
    def is_watertight(self) -> bool:
        """No boundary and no non-manifold edge (topology only; winding not looked at)."""
        return self.boundary_edges == 0 and self.nonmanifold_edges == 0

    @property
    def is_closed(self) -> bool:
        """Watertight and consistently wound: a closed surface, which bounds a volume.
        The same meaning as ``Mesh.is_closed`` (and ``Deformer``'s check)."""
        return self.is_watertight and self.misoriented_edges == 0

    @property
    def is_consistently_oriented(self) -> bool:
        return self.misoriented_edges == 0

    @property
    def is_inward(self) -> bool:
        """Closed, consistent, and the faces point inside (negative volume)."""
        return not math.isnan(self.signed_volume) and self.signed_volume < 0

    @property
    def is_volume(self) -> bool:
        """Closed, consistently oriented, outward: a volume vpffd can preserve."""
        return self.is_closed and self.is_consistently_oriented and self.signed_volume > 0

    def problems(self) -> list:
        """One line per defect found (empty for a clean closed mesh)."""
        out = []
        if self.boundary_edges:
            out.append(f"open: {self.boundary_edges} boundary edges in {self.boundary_loops} loops")
        if self.nonmanifold_edges:
            out.append(f"{self.nonmanifold_edges} non-manifold edges (more than two faces)")
        if self.nonmanifold_vertices:
            out.append(f"{self.nonmanifold_vertices} non-manifold vertices (pinch points)")
        if self.misoriented_edges:
            out.append(f"inconsistent orientation: {self.misoriented_edges} edges with both faces wound the same way")
        if self.is_inward:
            out.append(f"inward orientation: signed volume {self.signed_volume:.6g} < 0 (flip with orient=True)")
        if self.degenerate_faces:
            out.append(f"{self.degenerate_faces} degenerate (zero-area) faces")
        if self.duplicate_vertices:
            out.append(f"{self.duplicate_vertices} duplicate vertices (same position as another vertex)")
        if self.duplicate_faces:
            out.append(f"{self.duplicate_faces} duplicate faces")
        if self.unreferenced_vertices:
            out.append(f"{self.unreferenced_vertices} unreferenced vertices")
        if self.components > 1:
            out.append(f"{self.components} connected components")
        return out

    def as_dict(self) -> dict:
        return asdict(self)

    def __str__(self) -> str:
        head = (f"{self.vertices:,} vertices, {self.faces:,} faces, {self.edges:,} edges, "
                f"{self.components:,} component{'s' if self.components != 1 else ''}, "
                f"Euler characteristic {self.euler_characteristic}")
        if self.is_volume:
            verdict = f"closed, consistently oriented, outward: volume {self.signed_volume:.9g}"
        elif self.is_closed and self.is_consistently_oriented and self.is_inward:
            verdict = "closed and consistent, but inward"
        else:
            verdict = "does not bound a volume" if not self.is_closed or not self.is_consistently_oriented else \
                "closed"
        lines = [head, verdict]
        lines += ["  - " + p for p in self.problems()]
        return "\n".join(lines)
