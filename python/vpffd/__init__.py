"""vpffd: exact volume-preserving B-spline free-form deformation of triangle meshes.

>>> import vpffd
>>> mesh = vpffd.shapes.icosphere(4)
>>> lat = vpffd.Lattice.around(mesh, shape=(6, 6, 6), degree=3)
>>> r = vpffd.Deformer(mesh, lat).deform(vpffd.edits.squash(lat.control_points, 0.5))
>>> abs(r.volume - mesh.volume) < 1e-12 * mesh.volume
True
"""
from . import _core
from ._core import (BackendUnavailableError, DeviceError, InvalidInputError, MeshIOError,  # noqa: F401
                    SolverError)
from . import edits, shapes
from .deformer import Deformer, DeformResult, available_backends
from .edits import bend, scale, squash, taper, twist
from .lattice import Lattice
from .mesh import Mesh

__version__ = _core.__version__

__all__ = [
    "Mesh", "Lattice", "Deformer", "DeformResult", "available_backends",
    "twist", "bend", "taper", "scale", "squash", "edits", "shapes",
    "InvalidInputError", "SolverError", "MeshIOError", "BackendUnavailableError", "DeviceError",
]
