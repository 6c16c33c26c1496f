"""One evaluation of a mesh object by a lattice object through vpffd.

``evaluate`` reads the scene and runs vpffd without changing anything, raising
``Refused`` with a message for the artist when the input cannot be used;
``apply`` then writes the result (the lattice's points when they are first bound
to vpffd's control net, the "vpffd" shape key, the figures shown in the panel).
Keeping the two apart is what lets a refused operator leave the .blend as it was.

Spaces: vpffd works in the lattice object's local space (Blender's lattice box
is axis-aligned there). A = L^-1 M takes mesh-local coordinates there and A^-1
back. Affine maps scale every volume by the same |det|, so the volume kept in
lattice space is the volume kept in the mesh's own and in world space.
"""
from __future__ import annotations

import sys
from dataclasses import dataclass, field

import numpy as np

from . import mapping, rounding

LIVE_KEY = "vpffd"
BAKE_PREFIX = "vpffd_"
# On the Lattice datablock: [nu, nv, nw, du, dv, dw] of the vpffd control net its
# points currently show (absent: they are still offsets from Blender's rest grid).
BOUND_PROP = "vpffd_bound"


class Refused(Exception):
    """Input the add-on will not deform; the message is shown to the artist."""


def install_hint() -> str:
    py = sys.executable or "<Blender's python>"
    return (f"vpffd is not installed in Blender's Python ({py}, Python {sys.version_info[0]}.{sys.version_info[1]}). "
            f"Install it with that Python and restart Blender: \"{py}\" -m pip install /path/to/vpffd-checkout "
            "(or a vpffd wheel built for this Python version).")


def import_vpffd():
    """The vpffd module; Refused with the install instructions when it is missing."""
    try:
        import vpffd
    except ImportError as e:
        raise Refused(f"{install_hint()} ({e})") from None
    return vpffd


@dataclass
class Evaluation:
    """Everything one evaluation produced; nothing is written yet."""
    control_points: np.ndarray      # (nu, nv, nw, 3) what vpffd deformed, lattice-local, float32-representable
    degree: tuple
    snap: bool                      # the lattice's points must be rewritten to show control_points
    vertices: np.ndarray            # (V, 3) deformed, mesh-local, float64
    key: np.ndarray                 # (V, 3) float32 shape key to write (see rounding.py)
    result: object                  # vpffd.DeformResult (lattice-local)
    world_scale: float              # |det| from lattice-local volumes to world volumes
    notes: list = field(default_factory=list)
    folds: str = ""

    @property
    def volumes(self) -> tuple:
        """(rest, plain FFD, corrected) volumes in world units."""
        r, s = self.result, self.world_scale
        return r.rest_volume * s, r.volume_before * s, r.volume * s


@dataclass
class Cache:
    """What live updates keep between evaluations of one mesh object (runtime only)."""
    deformer_key: tuple = ()
    deformer: object = None
    topology: tuple = ()
    tris: np.ndarray = None
    n_poly: int = 0
    state: bytes = b""
    error: str = ""


def _matrix(m) -> np.ndarray:
    return np.array(m, dtype=np.float64).reshape(4, 4)


def read_points(lattice_data, attr: str) -> np.ndarray:
    co = np.empty(len(lattice_data.points) * 3, dtype=np.float32)
    lattice_data.points.foreach_get(attr, co)
    return co.astype(np.float64).reshape(-1, 3)


def read_rest(mesh_obj) -> np.ndarray:
    """(V, 3) float64 rest positions: the reference shape key's, else the vertices'."""
    me = mesh_obj.data
    co = np.empty(len(me.vertices) * 3, dtype=np.float32)
    if me.shape_keys is not None and me.shape_keys.reference_key is not None:
        me.shape_keys.reference_key.points.foreach_get("co", co)
    else:
        me.vertices.foreach_get("co", co)
    return co.astype(np.float64).reshape(-1, 3)


def read_mesh(mesh_obj) -> tuple:
    """(rest vertices (V, 3) float64 mesh-local, triangles (T, 3) int32, polygons that were not triangles).

    The rest shape is the reference shape key when there are shape keys (the
    live key sits on top of it), else the vertex positions. Faces are Blender's
    own triangulation of its polygons (``loop_triangles``), which does not touch
    the mesh data."""
    me = mesh_obj.data
    rest = read_rest(mesh_obj)
    if hasattr(me, "calc_loop_triangles"):
        me.calc_loop_triangles()
    tris = np.empty(len(me.loop_triangles) * 3, dtype=np.int32)
    me.loop_triangles.foreach_get("vertices", tris)
    sizes = np.empty(len(me.polygons), dtype=np.int32)
    me.polygons.foreach_get("loop_total", sizes)
    return rest, tris.reshape(-1, 3), int(np.count_nonzero(sizes != 3))


def _group_weights(lattice_obj, name: str, shape) -> np.ndarray:
    vg = lattice_obj.vertex_groups.get(name)
    if vg is None:
        raise Refused(f"the lattice '{lattice_obj.name}' has no vertex group named '{name}'")
    g = np.zeros(len(lattice_obj.data.points))
    for i, p in enumerate(lattice_obj.data.points):
        for e in p.groups:
            if e.group == vg.index:
                g[i] = e.weight
    return mapping.scalars_to_grid(g, shape)


def _objects(mesh_obj, settings):
    if mesh_obj is None or mesh_obj.type != 'MESH':
        raise Refused("select a mesh object (the active object) to deform")
    lat = settings.lattice
    if lat is None or lat.type != 'LATTICE':
        raise Refused(f"'{mesh_obj.name}' has no lattice object to deform it with (pick one in the vpffd panel, "
                      "or select the lattice too)")
    if len(mesh_obj.data.vertices) == 0:
        raise Refused(f"'{mesh_obj.name}' has no vertices")
    return lat


def state_signature(mesh_obj, settings) -> bytes:
    """Bytes that change whenever a live update would give a different result."""
    lat = settings.lattice
    parts = [read_points(lat.data, "co_deform").tobytes(), _matrix(lat.matrix_world).tobytes(),
             _matrix(mesh_obj.matrix_world).tobytes(), len(mesh_obj.data.vertices).to_bytes(8, "little"),
             repr((settings.preserve_volume, settings.exact_float32, settings.axes, settings.degree,
                   settings.weight_group, lat.data.points_u, lat.data.points_v, lat.data.points_w)).encode()]
    for t in settings.targets:
        parts.append(repr((t.vertex, None if t.empty is None else tuple(t.empty.matrix_world.translation))).encode())
    return b"".join(parts)


def evaluate(mesh_obj, settings, cache: Cache | None = None, exact_float32: bool = True) -> Evaluation:
    """Deforms ``mesh_obj`` by ``settings.lattice`` as the panel's settings say. Changes nothing.

    ``exact_float32=False`` rounds the result to the nearest float32 even when the
    settings ask for the volume-exact rounding (live updates while dragging: the
    rounding costs more than the frame on large meshes)."""
    vpffd = import_vpffd()
    lat = _objects(mesh_obj, settings)
    ld = lat.data
    shape = (ld.points_u, ld.points_v, ld.points_w)
    if min(shape) < 2:
        raise Refused(f"the lattice '{lat.name}' has resolution {shape[0]}x{shape[1]}x{shape[2]}; vpffd needs at "
                      "least 2 points along every axis")
    rest_co = read_points(ld, "co")
    try:
        box_min, box_max = mapping.lattice_box(rest_co)
    except ValueError as e:
        raise Refused(f"lattice '{lat.name}': {e}") from None
    degree = mapping.degrees_for(shape, settings.degree)
    vlat = vpffd.Lattice(box_min, box_max, shape=shape, degree=degree)

    # What the points show now, and the net they are offsets from.
    shown = mapping.blender_to_grid(read_points(ld, "co_deform"), shape)
    bound = [int(x) for x in ld.get(BOUND_PROP, [])]
    if len(bound) == 6 and tuple(bound[:3]) == shape:
        snap = tuple(bound[3:]) != degree
        shown_rest = (vlat.rest_points if not snap else
                      vpffd.Lattice(box_min, box_max, shape, tuple(bound[3:])).rest_points)
    else:
        snap, shown_rest = True, mapping.blender_to_grid(rest_co, shape)
    P = shown if not snap else mapping.rebased_points(shown, shown_rest, vlat.rest_points)
    # Blender stores points in float32: deform exactly the points the artist will see.
    P = P.astype(np.float32).astype(np.float64)

    notes = []
    me = mesh_obj.data
    topology = (len(me.vertices), len(me.polygons), len(me.loops))
    if cache is not None and cache.topology == topology:
        # Live updates: Blender's triangulation only changes with the topology.
        rest, tris, n_poly = read_rest(mesh_obj), cache.tris, cache.n_poly
    else:
        rest, tris, n_poly = read_mesh(mesh_obj)
        if cache is not None:
            cache.topology, cache.tris, cache.n_poly = topology, tris, n_poly
    if len(tris) == 0:
        raise Refused(f"'{mesh_obj.name}' has no faces")
    if n_poly:
        notes.append(f"triangulated {n_poly} quad/n-gon faces on the fly (the mesh itself is unchanged)")
    M, L = _matrix(mesh_obj.matrix_world), _matrix(lat.matrix_world)
    if abs(np.linalg.det(L[:3, :3])) < 1e-300 or abs(np.linalg.det(M[:3, :3])) < 1e-300:
        raise Refused("the mesh or the lattice object has a zero scale")
    A = np.linalg.solve(L, M)
    X = mapping.affine(A, rest)
    # Blender's box is float32 and A is a product of matrices: a vertex exactly on
    # the lattice's face may land a few ulps outside, which is not the artist's mistake.
    slack = 4 * np.finfo(np.float32).eps * np.abs(np.stack([box_min, box_max])).max()
    out = mapping.outside_count(X, box_min - slack, box_max + slack)
    if out:
        raise Refused(f"the lattice '{lat.name}' does not enclose '{mesh_obj.name}': {out} of {len(X)} vertices lie "
                      "outside it (scale or move the lattice so the whole mesh is inside)")
    X = np.clip(X, box_min, box_max)
    key = (mesh_obj.as_pointer(), lat.as_pointer(), shape, degree, bool(settings.preserve_volume), A.tobytes(),
           rest.tobytes(), tris.tobytes())
    deformer = cache.deformer if cache is not None and cache.deformer_key == key else None
    if deformer is None:  # a cached Deformer embeds this very mesh: it was checked when built
        try:
            vmesh = vpffd.Mesh(X, tris)
        except vpffd.InvalidInputError as e:
            raise Refused(f"'{mesh_obj.name}': {e}") from None
        if settings.preserve_volume and not vmesh.is_closed:
            report = vmesh.check()
            e = vmesh.edge_report()
            raise Refused(f"'{mesh_obj.name}' is open or non-manifold, so it has no volume to preserve "
                          f"({e['boundary_edges']} boundary edges, {e['nonmanifold_edges']} non-manifold edges, "
                          f"{e['misoriented_edges']} inconsistently wound); close it (e.g. Fill Holes) or switch "
                          f"volume preservation off. {str(report).splitlines()[0] if str(report) else ''}".strip())

    weights = fixed = None
    if settings.weight_group:
        weights, fixed = mapping.group_weights(_group_weights(lat, settings.weight_group, shape))
    Linv = np.linalg.inv(L)
    constraints = []
    for i, t in enumerate(settings.targets):
        if t.empty is None:
            raise Refused(f"target {i + 1} has no empty object")
        if not 0 <= t.vertex < len(X):
            raise Refused(f"target {i + 1} ('{t.empty.name}') names vertex {t.vertex}, but '{mesh_obj.name}' has "
                          f"{len(X)} vertices")
        constraints.append((int(t.vertex), mapping.affine(Linv, np.array(t.empty.matrix_world.translation))[0]))
    fixed_axes = [a for a in range(3) if "xyz"[a] not in settings.axes]
    if constraints and fixed_axes:
        # A vertex can only be pulled along the corrected axes; along the others it
        # stays where the plain FFD puts it (an empty dragged in the viewport always
        # moves a little along every axis, if only by float32 rounding).
        plain = vlat.deform_points(X[[v for v, _ in constraints]], control_points=P)
        for (_, target), p in zip(constraints, plain):
            target[fixed_axes] = p[fixed_axes]

    try:
        if deformer is None:
            deformer = vpffd.Deformer(vmesh, vlat)
        r = deformer.deform(P, preserve_volume=bool(settings.preserve_volume), axes=settings.axes,
                            weights=weights, fixed=fixed, constraints=constraints or None)
    except (vpffd.InvalidInputError, vpffd.SolverError) as e:
        raise Refused(f"vpffd could not deform '{mesh_obj.name}': {e}") from None
    if cache is not None:
        cache.deformer_key, cache.deformer = key, deformer

    folds = ""
    if hasattr(vpffd, "check_folds"):
        try:
            rep = vpffd.check_folds(vlat, r.control_points)
            if getattr(rep, "folded", False):
                folds = "folded (the corrected lattice turns the mesh inside out somewhere)"
            else:
                folds = "certified fold-free" if getattr(rep, "certified", False) else "not certified (undecided cells)"
        except Exception as e:  # a verdict we cannot compute must not hide the deformation itself
            folds = f"fold check failed: {e}"
    Y = mapping.affine(np.linalg.inv(A), r.vertices)
    if settings.preserve_volume and settings.exact_float32 and exact_float32:
        key = rounding.volume_exact_key(Y, rest.astype(np.float32), tris, rounding.volume(rest, tris))
    else:
        key = Y.astype(np.float32)
    return Evaluation(control_points=P, degree=degree, snap=snap, vertices=Y, key=key, result=r,
                      world_scale=abs(float(np.linalg.det(L[:3, :3]))), notes=notes, folds=folds)


def write_shape_key(mesh_obj, name: str, vertices) -> object:
    """Writes (V, 3) mesh-local positions (float32 as given, else rounded) into shape key
    ``name`` (created after a Basis when missing)."""
    if mesh_obj.data.shape_keys is None:
        mesh_obj.shape_key_add(name="Basis", from_mix=False)
    kb = mesh_obj.data.shape_keys.key_blocks.get(name)
    if kb is None:
        kb = mesh_obj.shape_key_add(name=name, from_mix=False)
    # ShapeKey.points takes a raw float buffer (~0.1 ms for 100k points); .data goes point by point.
    kb.points.foreach_set("co", np.ascontiguousarray(vertices, dtype=np.float32).ravel())
    mesh_obj.data.update()
    return kb


def write_lattice(lattice_obj, ev: Evaluation) -> None:
    """Shows vpffd's control points as the Blender lattice's points and marks the lattice bound."""
    ld = lattice_obj.data
    ld.points.foreach_set("co_deform", mapping.grid_to_blender(ev.control_points).astype(np.float32).ravel())
    ld[BOUND_PROP] = [ld.points_u, ld.points_v, ld.points_w, *ev.degree]
    ld.update_tag()


def write_figures(settings, ev: Evaluation) -> None:
    rest, plain, after = ev.volumes
    settings.volume_rest, settings.volume_plain, settings.volume_after = rest, plain, after
    settings.fold_verdict = ev.folds


def apply(mesh_obj, settings, ev: Evaluation) -> None:
    """Writes an evaluation: the lattice's points if they had to be rebound, the live key, the panel's figures."""
    if ev.snap:
        write_lattice(settings.lattice, ev)
    kb = write_shape_key(mesh_obj, LIVE_KEY, ev.key)
    kb.value = 1.0
    write_figures(settings, ev)
