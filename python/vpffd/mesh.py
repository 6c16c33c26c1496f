"""Triangle meshes as plain numpy arrays."""
from __future__ import annotations

import sys

import numpy as np

from . import _arrays, _core


class Mesh:
    """A triangle mesh: ``vertices`` (V, 3) float64 and ``faces`` (F, 3) int32.

    Both arrays are copied on construction and stored read-only, so a Mesh never
    changes under a Deformer that uses it.

    Parameters
    ----------
    vertices : array_like, (V, 3), real
    faces : array_like, (F, 3), integer indices into ``vertices``

    Raises
    ------
    TypeError
        for non-numeric vertices or non-integer faces.
    vpffd.InvalidInputError (a ValueError)
        for wrong shapes, NaN/Inf, an empty mesh or face indices out of range.
    """

    def __init__(self, vertices, faces):
        V = _arrays.points(vertices, "Mesh: vertices")
        F = _arrays.faces(faces, V.shape[0], "Mesh: faces")
        V.setflags(write=False)
        F.setflags(write=False)
        self._V, self._F = V, F
        self._edges = None
        self._box = None
        self._normals = None
        self._source = None  # the file it was read from (load_mesh), for its up-axis convention

    def _with_vertices(self, V: np.ndarray) -> "Mesh":
        """The same faces with new vertices ``V``: a checked (#V, 3) float64 array that
        this Mesh takes over (the faces and their edge report are shared, not checked again)."""
        m = Mesh.__new__(Mesh)
        V.setflags(write=False)
        m._V, m._F, m._edges, m._box, m._normals = V, self._F, self._edges, None, None
        m._source = self._source
        return m

    @classmethod
    def from_any(cls, obj) -> "Mesh":
        """A Mesh from a Mesh, a (vertices, faces) pair, or any object with
        ``vertices`` and ``faces`` arrays (trimesh and friends)."""
        if isinstance(obj, Mesh):
            return obj
        if isinstance(obj, tuple) and len(obj) == 2:
            return cls(*obj)
        if hasattr(obj, "vertices") and hasattr(obj, "faces"):
            return cls(np.asarray(obj.vertices), np.asarray(obj.faces))
        raise TypeError(f"expected a vpffd.Mesh, a (vertices, faces) pair or an object with vertices and faces, "
                        f"got {type(obj).__name__}")

    @property
    def vertices(self) -> np.ndarray:
        """(V, 3) float64, read-only."""
        return self._V

    @property
    def faces(self) -> np.ndarray:
        """(F, 3) int32, read-only."""
        return self._F

    @property
    def n_vertices(self) -> int:
        return self._V.shape[0]

    @property
    def n_faces(self) -> int:
        return self._F.shape[0]

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3), read-only: minimum and maximum corner of the bounding box."""
        if self._box is None:  # the vertices are read-only: computed once
            self._box = np.stack(_arrays.bounds(self._V))
            self._box.setflags(write=False)
        return self._box

    def _vertex_normals(self) -> np.ndarray:
        """vertex_normals of this mesh, computed once (read-only): the rest normals
        every exact deformed-normals frame starts from."""
        if self._normals is None:
            self._normals = _core.vertex_normals(self._V, self._F)
            self._normals.setflags(write=False)
        return self._normals

    def edge_report(self) -> dict:
        """Counts of edges, boundary edges, non-manifold edges and edges used twice
        in the same direction (inconsistent winding)."""
        if self._edges is None:
            self._edges = _core.edge_report(self._F)
        return dict(self._edges)

    @property
    def is_closed(self) -> bool:
        """True when every edge has exactly two faces, wound consistently: a closed
        surface, which bounds a volume. The same meaning as ``MeshCheck.is_closed``;
        ``check().is_watertight`` looks at the topology alone."""
        e = self.edge_report()
        return e["boundary_edges"] == 0 and e["nonmanifold_edges"] == 0 and e["misoriented_edges"] == 0

    @property
    def volume(self) -> float:
        """Enclosed (signed) volume, positive for outward-facing faces.

        Raises vpffd.InvalidInputError for a mesh that is not closed, saying how
        many boundary (or non-manifold, or misoriented) edges it has, and for a
        volume outside the range of normal doubles (say, coordinates near 1e300 or
        1e-150), saying which way; any finite coordinates otherwise give a finite
        volume."""
        # The faces never change, so their edge report (a sort of 3F edges, the
        # costly part) is computed once; require_closed only runs to word the error.
        if not self.is_closed:
            _core.require_closed(self._F, "Mesh.volume")
        lo, hi = self.bounds
        centre = 0.5 * lo + 0.5 * hi  # the mean, without overflow near the double range's ends
        reach = float(np.max(np.maximum(hi - centre, centre - lo)))
        if reach == 0.0:
            return 0.0
        # Summed in units of a power of two near the mesh's size, so that the triple
        # products neither overflow (coordinates near 1e300) nor underflow (near
        # 1e-150); the scaling is exact, so the bits are those of the plain sum
        # wherever that sum is in range.
        s = float(np.ldexp(1.0, int(np.frexp(reach)[1]) - 1))  # reach / s in [1, 2)
        v = _core.signed_volume(self._V / s, self._F, centre / s, False)  # arrays checked in __init__
        volume = v * s * s * s
        if not np.isfinite(volume):
            raise _core.InvalidInputError(f"Mesh.volume: the enclosed volume ({v:.6g} x {s:.6g}^3) is beyond "
                                          "the double range (1.8e308); scale the mesh down")
        if v != 0.0 and abs(volume) < sys.float_info.min:
            raise _core.InvalidInputError(f"Mesh.volume: the enclosed volume ({v:.6g} x {s:.6g}^3) is below the "
                                          "smallest normal double (2.2e-308); scale the mesh up")
        return volume

    def check(self):
        """Defect report: boundary edges and loops, non-manifold edges and vertices,
        inconsistent or inward orientation, degenerate and duplicate faces,
        duplicate and unreferenced vertices, components (a ``vpffd.check.MeshCheck``;
        ``print`` it for a readable summary). Counted on the faces as stored."""
        from .check import MeshCheck
        return MeshCheck.of(self._V, self._F)

    def oriented(self) -> "Mesh":
        """A new Mesh with consistent winding and every closed component facing
        outward (positive volume); self when nothing needs flipping. Open components
        keep the winding of the majority of their faces."""
        F, flipped, _conflicts, _inward = _core.orient_faces(self._V, self._F)
        if flipped == 0:
            return self
        return Mesh(self._V, F)

    def flipped(self) -> "Mesh":
        """A new Mesh with every face's winding reversed (normals point the other way)."""
        return Mesh(self._V, self._F[:, ::-1])

    def to_trimesh(self):
        """A ``trimesh.Trimesh`` with the same vertices and faces in the same order
        (needs trimesh; ImportError saying so otherwise)."""
        from .interop import to_trimesh
        return to_trimesh(self._V, self._F)

    def _repr_png_(self):
        """Jupyter picture (Embree render, volume in the caption); None without Embree."""
        from .notebook import mesh_png
        return mesh_png(self)

    def __repr__(self) -> str:
        return f"Mesh({self.n_vertices} vertices, {self.n_faces} faces)"
