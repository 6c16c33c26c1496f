"""DeformResult: one deformed frame, as every backend returns it."""
from __future__ import annotations

import weakref
from dataclasses import dataclass, field

import numpy as np

from . import _core

InvalidInputError = _core.InvalidInputError


@dataclass
class DeformResult:
    """One deformed frame.

    Attributes
    ----------
    vertices : (V, 3) float64
        the corrected mesh vertices.
    control_points, offsets : (nu, nv, nw, 3) float64
        corrected control points and the offsets delta added to the input ones.
    volume : float
        enclosed volume of ``vertices`` (measured, not predicted).
    volume_before : float
        volume after the plain FFD, before any correction.
    target_volume, rest_volume : float
        the volume aimed at (NaN without ``preserve_volume``) and that of the rest mesh
        the frame deformed (NaN for an open mesh without ``allow_open``). After a move of
        the rest mesh a frame that does not need the rest volume does not sum it:
        ``rest_volume`` is then summed when first read (the same number, one pass
        over the faces; ``RestVolumeSource``).
    constraint_error : float
        largest coordinate error of the point constraints (0 without constraints).
    steps : list of dict
        per axis step: axis, volume_before, share, sum_squares, max_offset.
    backend, method : str
        the backend and the coefficient method that actually ran ("traversal" on
        "vulkan", whatever was asked).
    faces : (F, 3) int32 or None
        the mesh's faces (shared, read-only), so the result is a mesh by itself.
    folds : FoldReport or None
        the fold check of the corrected control points (``Deformer.check_folds``)
        when ``deform`` ran with ``on_fold`` other than "ignore"; None when unchecked.
    normals : (V, 3) float64 or None
        with ``deform(..., normals=True)``: unit normals of the deformed surface at
        its vertices (``deformed_normals`` of the corrected control points: exact,
        cof(J) n0). On "vulkan" computed on the device in the frame's submission.
    part_volumes, part_volumes_before : (K,) float64 or None
        with a Deformer built with ``parts``: the volume of each part in the result
        (measured) and after the plain FFD, in the order of ``Deformer.part_labels``.
    part_target_volumes : (K,) float64 or None
        with parts and ``preserve_volume``: the volume each part was corrected to
        (``volume``, ``target_volume`` and ``rest_volume`` are then the sums).
    constraints : (sources (k, 3), targets (k, 3)) float64 read-only, or None
        the frame's point constraints: rest-space points (a vertex's rest position
        for a vertex index) and the world positions they were taken to; the form
        ``deform(constraints=...)`` takes.
    """
    vertices: np.ndarray
    control_points: np.ndarray
    offsets: np.ndarray
    volume: float
    volume_before: float
    target_volume: float
    rest_volume: float
    constraint_error: float
    steps: list = field(default_factory=list)
    backend: str = ""
    method: str = ""
    faces: np.ndarray = None
    folds: object = None
    normals: np.ndarray = None
    part_volumes: np.ndarray = None
    part_volumes_before: np.ndarray = None
    part_target_volumes: np.ndarray = None
    constraints: tuple = None

    def __post_init__(self):
        # A RestVolumeSource in place of the number: kept aside until rest_volume is read.
        if isinstance(self.rest_volume, RestVolumeSource):
            self.__dict__["_rest_volume_source"] = self.__dict__.pop("rest_volume")

    def __getattr__(self, name):
        # Reached only for attributes not set: rest_volume before its first read.
        source = self.__dict__.get("_rest_volume_source") if name == "rest_volume" else None
        if source is None:
            raise AttributeError(f"'{type(self).__name__}' object has no attribute '{name}'")
        value = source()
        self.__dict__["rest_volume"] = value
        del self.__dict__["_rest_volume_source"]
        return value

    def __getstate__(self):
        # Copies and pickles carry the number, not the source (which refers to a Deformer).
        _ = self.rest_volume
        return dict(self.__dict__)

    def __repr__(self) -> str:
        # A few lines of numbers, not the arrays (print(result.vertices) shows those).
        shape = "x".join(map(str, self.control_points.shape[:3]))
        rest = self.__dict__.get("rest_volume")  # not summed yet: not summed for a repr either
        rest_txt = "rest not summed yet" if rest is None else f"rest {rest:.6g}"
        lines = [f"DeformResult({self.vertices.shape[0]} vertices, lattice {shape}, backend {self.backend!r}, "
                 f"method {self.method!r}"]
        vol = f"  volume {self.volume:.6g} ({rest_txt}, plain FFD {self.volume_before:.6g}"
        if np.isfinite(self.target_volume):
            vol += f", target {self.target_volume:.6g}, relative error {self.volume_error:.1e}"
        lines.append(vol + ")")
        axes = "".join(_axis_name(s.get("axis")) if isinstance(s, dict) else "" for s in self.steps)
        what = [f"corrected in {len(self.steps)} axis step{'s' * (len(self.steps) != 1)} ({axes})"
                if self.steps else "not corrected"]
        if self.constraints is not None:
            what.append(f"{len(self.constraints[0])} constraints met to {self.constraint_error:.1e}")
        if self.part_volumes is not None:
            what.append(f"{len(self.part_volumes)} parts")
        if self.normals is not None:
            what.append("normals")
        what.append("folds: " + (self.folds.verdict(short=True) if self.folds is not None else "not checked"))
        lines.append("  " + "; ".join(what) + ")")
        return "\n".join(lines)

    def to_trimesh(self):
        """The deformed mesh as a ``trimesh.Trimesh`` (vertex order kept; needs trimesh)."""
        if self.faces is None:
            raise InvalidInputError("to_trimesh: this result carries no faces")
        from .interop import to_trimesh
        return to_trimesh(self.vertices, self.faces)

    def _repr_png_(self):
        """Jupyter picture of the deformed mesh and its corrected control points, volumes in the caption."""
        from .notebook import result_png
        return result_png(self)

    @property
    def volume_error(self) -> float:
        """|volume - target| / |target| (NaN without a target, inf for a zero target)."""
        return float(np.float64(abs(self.volume - self.target_volume)) / np.float64(abs(self.target_volume))) \
            if self.target_volume != 0 else (0.0 if self.volume == 0 else float("inf"))

    @property
    def volume_change_before(self) -> float:
        """Relative volume change of the plain FFD against the rest volume."""
        if self.rest_volume == 0:
            return float("nan")
        return (self.volume_before - self.rest_volume) / self.rest_volume


def _axis_name(a) -> str:
    return "xyz"[int(a)] if isinstance(a, (int, np.integer)) and 0 <= a < 3 else str(a or "")


class RestVolumeSource:
    """DeformResult.rest_volume before its first read: the volume of the rest mesh a
    frame deformed, summed on demand. After a move the rest volume is summed on first
    use (plain frames and the move itself do not need it), and a result asks for it
    only if it is read.

    While the rest mesh is the Deformer's current one it asks the core, which keeps the
    sum. When the rest mesh moves on, the source keeps the old rest vertices (or their
    sum, if it was known) and asks for their sum (``rest_volume_of``: the same faces,
    parts and order, the same bits). It refers to its Deformer weakly: a Deformer about
    to go sums what its results have not read (``Deformer.__del__``), so results never
    keep a Deformer's memory alive."""
    __slots__ = ("_deformer", "_vertices", "_value", "__weakref__")

    def __init__(self, deformer):
        self._deformer = weakref.ref(deformer)
        self._vertices = None  # None while this is the Deformer's current rest mesh
        self._value = None

    def retire(self, vertices, value=None):
        """The Deformer's rest mesh moves on from ``vertices``; ``value`` is their sum if known."""
        if self._value is None:
            self._value = value
            self._vertices = vertices if value is None else None

    def resolve(self, holder) -> float:
        """The sum, asked of ``holder`` (the Deformer's core or Vulkan deformer) if not known."""
        if self._value is None:
            self._value = float(holder.rest_volume(True) if self._vertices is None
                                else holder.rest_volume_of(self._vertices))
            self._vertices = None
        return self._value

    def __call__(self) -> float:
        if self._value is None:
            d = self._deformer()
            if d is None:  # Deformer.__del__ resolves every source it handed out first
                raise RuntimeError("rest_volume: the Deformer of this result is gone before its rest volume was summed")
            return self.resolve(d._holder)
        return self._value
