"""Mesh files (C++: vpffd's own readers for every format and writers for all but OM;
OpenMesh, Debian's libopenmesh-dev, writes OM).

Writes never lose a file: the new one is written to a temporary file in the same
folder, every write checked, flushed to the disk and only then renamed over the old
one; a write that fails raises and leaves the old file as it was.

Formats: ``.obj``, ``.off``, ``.ply`` (ASCII and binary), ``.stl`` (ASCII and
binary), ``.om``; any of them gzip-compressed as ``name.ply.gz`` etc. (reading).
"""
from __future__ import annotations

import logging
import os
import time
import warnings

import numpy as np

from . import _core
from .mesh import Mesh

MeshIOError = _core.MeshIOError
InvalidInputError = _core.InvalidInputError
BackendUnavailableError = _core.BackendUnavailableError

_log = logging.getLogger(__name__)

#: Extensions load_mesh and save_mesh accept (empty when the build has no mesh file
#: I/O; without OpenMesh, save_mesh refuses ``.om``).
FORMATS = tuple(_core.mesh_formats()) if _core.has_mesh_io else ()


def _path(path, where: str) -> bytes:
    """The file name as the bytes the OS gets: str, bytes or os.PathLike, any name the OS allows.

    A str is encoded like ``open()`` does (``os.fsencode``: UTF-8 with surrogate
    escapes, so names that are not UTF-8 survive ``os.listdir`` and back); an
    embedded NUL byte reaches C++, which refuses it with a MeshIOError.
    """
    if not isinstance(path, (str, bytes, os.PathLike)):
        raise TypeError(f"{where}: expected a file name (str, bytes or os.PathLike), got {type(path).__name__}")
    return os.fsencode(path)


def _file_size(p: bytes) -> str:
    try:
        n = os.stat(p).st_size
    except OSError:
        return "size unknown"
    return f"{n / 2 ** 20:.1f} MiB" if n >= 2 ** 20 else f"{n / 2 ** 10:.1f} KiB"


def _require_mesh_io(where: str) -> None:
    if not _core.has_mesh_io:
        raise BackendUnavailableError(f"{where}: this build of vpffd has no mesh file I/O (zlib was not found "
                                      "at build time; Debian/Ubuntu: apt-get install zlib1g-dev, then rebuild)")


def _require_writer(path, where: str) -> None:
    """Refuses, before any work, a file this build cannot write: none without mesh
    file I/O, ``.om`` without OpenMesh (which writes OM's halfedge connectivity)."""
    _require_mesh_io(where)
    if not _core.has_openmesh and os.fsdecode(path).lower().endswith(".om"):
        raise BackendUnavailableError(f"{where}: this build of vpffd writes no .om files (OpenMesh was not found "
                                      "at build time; Debian/Ubuntu: apt-get install libopenmesh-dev, then "
                                      "rebuild); it writes .obj, .off, .ply and .stl and reads every format "
                                      "without it")


def load_mesh(path, orient: bool = False, return_normals: bool = False):
    """Reads a triangle mesh file.

    Faces come back exactly as stored (polygons split into triangle fans): no
    vertex is merged and no face is dropped, so ``mesh.check()`` reports the
    defects of the file itself. This holds for every format: a face with a
    repeated corner (OBJ ``f 1 1 1``, OFF ``3 0 0 0``) is returned as stored
    (``f 1 2 2 3`` gives the fan ``[0, 1, 1], [0, 1, 2]``); only faces with fewer
    than 3 corners are left out (``_core.read_mesh`` counts them in
    ``skipped_faces``). STL is the exception that has no shared vertices: its
    reader merges equal positions.

    Parameters
    ----------
    path : str, bytes or os.PathLike
        ``.obj``, ``.off``, ``.ply``, ``.stl`` or ``.om``, optionally followed by ``.gz``.
        Any name the OS allows (bytes that are not UTF-8 included).
    orient : bool
        make the winding consistent and turn closed components outward
        (``Mesh.oriented``), e.g. for a mesh whose normals point inside.
    return_normals : bool
        also return the file's vertex normals, (V, 3) float64, or None.

    Returns
    -------
    Mesh, or (Mesh, normals) with ``return_normals``.

    Warns
    -----
    UserWarning
        what the reader converted, e.g. a PLY whose coordinates are stored as
        integers (read as float64).

    Raises
    ------
    vpffd.MeshIOError (an OSError)
        the file is missing, empty, truncated, not a mesh, has no faces, an
        unknown extension, a non-finite coordinate (``nan``, ``inf``, ``1e400``),
        a line of an ASCII file that does not parse completely or has the wrong
        number of values, counts in a header that the file's size cannot hold,
        corrupt connectivity, a .gz that decompresses to more than the memory
        allows, a NUL byte in the name, ...: the message names the file (bytes
        that are not printable UTF-8 written as ``\\xNN``), the problem and, for
        ASCII files, the line.
    TypeError
        ``path`` is not a file name.
    """
    p = _path(path, "load_mesh")
    _require_mesh_io("load_mesh")
    t0 = time.perf_counter()
    try:
        d = _core.read_mesh(p)
    except MemoryError as e:  # the arrays' conversion to NumPy; C++ turns its own bad_alloc into MeshIOError
        raise MeshIOError(f"load_mesh: '{p.decode('utf-8', 'backslashreplace')}': out of memory while "
                          "returning the mesh") from e
    for note in d.get("notes", ()):
        warnings.warn(f"load_mesh: '{p.decode('utf-8', 'backslashreplace')}': {note}", stacklevel=2)
    mesh = Mesh(d["vertices"], d["faces"])
    # The file's name, for its format's up-axis convention (views.guess_up_axis).
    mesh._source = os.fsdecode(p)
    _log.info("read %s: %d vertices, %d faces, %s in %.2f s", mesh._source, mesh.n_vertices, mesh.n_faces,
              _file_size(p), time.perf_counter() - t0)
    normals = d["normals"]
    if orient:
        # File normals are returned as stored: they are data, not derived from the winding.
        mesh = mesh.oriented()
        mesh._source = os.fsdecode(p)
    if return_normals:
        return mesh, normals
    return mesh


def save_mesh(path, mesh, normals=None, binary=None, precision: int = 17) -> None:
    """Writes a triangle mesh file (format from the extension).

    Parameters
    ----------
    path : str, bytes or os.PathLike
        ``.obj``, ``.off``, ``.ply``, ``.stl`` or ``.om`` (no ``.gz``).
    mesh : Mesh, (vertices, faces) pair, or any object with vertices and faces
    normals : (V, 3) array_like, optional
        vertex normals to store (OBJ, OFF, PLY, OM; STL stores the normal of each
        triangle, computed from its corners, instead).
    binary : bool, optional
        default: binary for PLY, STL and OM, ASCII for OBJ and OFF.
    precision : int
        significant digits of ASCII numbers, 1..17. 17 (the default) writes the
        shortest text that reads back to the very same float64, so ASCII OBJ, OFF,
        PLY and STL files round-trip exactly. Binary PLY and OM store float64
        (exact); binary STL stores float32 by the format's definition, and so does
        binary OFF (relative error ~6e-8, a deformed mesh's volume changes by ~1e-7
        relative).

    Every face is written as given, non-manifold ones and faces with a repeated
    corner included, except in ``.om`` files (below). STL has no shared vertices:
    reading it back merges vertices at equal positions and loses vertices no face
    uses.

    Warns
    -----
    UserWarning
        for ``.om`` only, when OpenMesh's halfedge structure (which OM stores)
        cannot hold the mesh as is: non-manifold faces are written with their own
        copies of their vertices, faces with a repeated vertex index are dropped.

    Raises
    ------
    vpffd.MeshIOError
        the folder does not exist or is not writable, unknown extension, a target
        that cannot be replaced safely (a FIFO, a device), a full disk or the
        process's file-size limit, ...: the message names the file and the
        operating system's error; an existing file is left byte for byte as it was
        and no temporary file remains.
    vpffd.InvalidInputError
        bad normals (shape, NaN), ``binary=True`` for OBJ, ``binary=False`` for
        OM, non-finite coordinates (naming the vertex), coordinates beyond
        float32's range (3.4e38) for binary OFF and STL.
    vpffd.BackendUnavailableError
        ``.om`` in a build without OpenMesh.
    """
    p = _path(path, "save_mesh")
    m = Mesh.from_any(mesh)
    _require_writer(p, "save_mesh")
    N = None
    if normals is not None:
        from . import _arrays
        N = _arrays.points(normals, "save_mesh: normals", rows=m.n_vertices)
    if binary is None:
        b = -1
    elif isinstance(binary, (bool, np.bool_)):
        b = int(bool(binary))
    else:
        raise TypeError(f"save_mesh: binary must be a bool or None, got {type(binary).__name__}")
    if isinstance(precision, bool) or not isinstance(precision, (int, np.integer)):
        raise TypeError(f"save_mesh: precision must be an integer, got {type(precision).__name__}")
    t0 = time.perf_counter()
    r = _core.write_mesh(p, m.vertices, m.faces, N, b, int(precision))
    _log.info("wrote %s: %d vertices, %d faces, %s in %.2f s", os.fsdecode(p), m.n_vertices, m.n_faces,
              _file_size(p), time.perf_counter() - t0)
    if r["split_faces"] or r["dropped_faces"]:
        warnings.warn(f"save_mesh: '{p.decode('utf-8', 'backslashreplace')}': {r['split_faces']} non-manifold faces were written with their own copies "
                      f"of their vertices, {r['dropped_faces']} faces with a repeated vertex index were dropped",
                      stacklevel=2)
