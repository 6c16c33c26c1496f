"""Conversions to other mesh libraries (optional dependencies, imported on use)."""
from __future__ import annotations

import numpy as np


def to_trimesh(vertices, faces):
    """A ``trimesh.Trimesh`` with copies of (V, 3) ``vertices`` and (F, 3) ``faces``,
    in the same order (trimesh's merging and clean-up are off, so vertex i stays vertex i).

    Raises ImportError naming the package to install when trimesh is missing."""
    try:
        import trimesh
    except ImportError:
        raise ImportError("to_trimesh needs the trimesh package: pip install trimesh "
                          "(or pip install \"vpffd[all]\")") from None
    return trimesh.Trimesh(vertices=np.array(vertices, dtype=np.float64), faces=np.array(faces, dtype=np.int64),
                           process=False, validate=False)
