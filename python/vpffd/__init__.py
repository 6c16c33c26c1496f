"""vpffd: exact volume-preserving B-spline free-form deformation of triangle meshes.

>>> import vpffd
>>> mesh = vpffd.shapes.icosphere(4)
>>> lat = vpffd.Lattice.around(mesh, shape=(6, 6, 6), degree=3)
>>> r = vpffd.Deformer(mesh, lat).deform(vpffd.edits.squash(lat.control_points, 0.5))
>>> abs(r.volume - mesh.volume) < 1e-12 * mesh.volume
True
"""
import os as _os

from ._cpu import check_isa as _check_isa

_check_isa()
# libgomp's default lets idle threads spin at every barrier; on a machine whose
# cores are shared (laptops, CI, notebooks next to a compiler) a spinning team
# then waits a scheduler tick (4 ms) per parallel region, several times a frame,
# where sleeping waits cost microseconds. libgomp reads OMP_WAIT_POLICY once, when
# it is loaded: vpffd asks for passive waits only while _core loads it, only when
# the user has not chosen a policy, and puts the environment back as it found it
# (child processes and libraries loaded later see no change). A process that had
# loaded libgomp before importing vpffd keeps its own policy.
_policy_was_set = "OMP_WAIT_POLICY" in _os.environ
if not _policy_was_set:
    _os.environ["OMP_WAIT_POLICY"] = "PASSIVE"
try:
    from . import _core  # noqa: E402
finally:
    if not _policy_was_set:
        del _os.environ["OMP_WAIT_POLICY"]
from ._core import (BackendUnavailableError, DeviceError, InvalidInputError, MeshIOError,  # noqa: F401
                    SolverError)
from . import edits, shapes
from .deformer import Deformer, DeformResult, available_backends, vulkan_devices
from .edits import bend, scale, squash, taper, twist
from .lattice import Lattice
from .multires import Multires, MultiresDeformer, MultiresResult
from .details import DetailChange, detail_change
from .rbf import RBFDeformer
from . import subdivision
from .subdivision import SubdivisionAffineGroup, SubdivisionMultires
from . import subdivision_edits
from .mesh import Mesh
from . import check, normals, io, folds, local_weights
from .folds import FoldError, FoldReport, FoldWarning, check_folds
from .check import MeshCheck
from .io import load_mesh, save_mesh
from .normals import deformed_normals, vertex_normals
# Pictures: vpffd.camera, picking, colormap, rendering and comparison are the
# modules; their main names are re-exported here (vpffd.render is the function).
from . import camera, picking, colormap, rendering, comparison, subdivision_picture, views
from .camera import Camera
from .picking import Hit, Scene, pick, pick_pixel
from .rendering import render
from .comparison import local_volume_change, render_comparison
from .views import guess_up_axis
from ._png import save_png, load_png
from . import animate
from .animate import run_animation

__version__ = _core.__version__

__all__ = [
    "Mesh", "Lattice", "Deformer", "DeformResult", "available_backends", "vulkan_devices",
    "twist", "bend", "taper", "scale", "squash", "edits", "shapes", "animate", "run_animation",
    "InvalidInputError", "SolverError", "MeshIOError", "BackendUnavailableError", "DeviceError",
    "load_mesh", "save_mesh", "MeshCheck", "check", "render", "save_png", "load_png", "Camera", "Hit", "Scene",
    "pick", "pick_pixel", "vertex_normals", "deformed_normals", "normals", "io",
    "render_comparison", "local_volume_change", "guess_up_axis",
    "folds", "check_folds", "FoldReport", "FoldError", "FoldWarning", "local_weights",
    "Multires", "MultiresDeformer", "MultiresResult", "DetailChange", "detail_change", "RBFDeformer",
    "views", "subdivision", "SubdivisionMultires", "SubdivisionAffineGroup", "subdivision_edits", "subdivision_picture",
]
