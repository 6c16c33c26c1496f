"""DeformResult: one deformed frame, as every backend returns it."""
from __future__ import annotations

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
