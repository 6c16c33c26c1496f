"""Blender side: settings on the mesh object, operators, the sidebar panel, live handlers."""
from __future__ import annotations

import time

import bpy
import numpy as np
from bpy.app.handlers import persistent
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty,
                       StringProperty)

from . import engine

AXES = [(a, a, f"correct the volume by moving control points along the lattice's local {', '.join(a)}")
        for a in ("xyz", "xy", "xz", "yz", "x", "y", "z")]


def _is_lattice(_self, obj):
    return obj.type == 'LATTICE'


def _is_empty(_self, obj):
    return obj.type == 'EMPTY'


class VPFFD_Target(bpy.types.PropertyGroup):
    empty: PointerProperty(name="Empty", type=bpy.types.Object, poll=_is_empty,
                           description="where the vertex must go (vpffd point constraint)")
    vertex: IntProperty(name="Vertex", min=0, description="index of the mesh vertex dragged to the empty")


def _live_changed(self, context):
    # Switching live on evaluates at once (through the handler on the next update).
    _caches.pop(self.id_data.name_full, None)


class VPFFD_Settings(bpy.types.PropertyGroup):
    lattice: PointerProperty(name="Lattice", type=bpy.types.Object, poll=_is_lattice,
                             description="lattice object whose points drive the volume-preserving deformation")
    preserve_volume: BoolProperty(name="Preserve volume", default=True,
                                  description="correct the control points so the enclosed volume stays exact")
    exact_float32: BoolProperty(name="Exact in float32", default=True,
                                description="choose the float32 rounding of the result so that the mesh Blender "
                                            "shows keeps the volume to double precision (else ~1e-8); done by "
                                            "the operator and the bake, not by live updates while dragging")
    axes: EnumProperty(name="Axes", items=AXES, default="xyz",
                       description="lattice-local axes the correction may move control points along")
    degree: IntProperty(name="Degree", default=3, min=1, max=5,
                        description="B-spline degree per axis (lowered to points - 1 on short axes)")
    weight_group: StringProperty(name="Stiffness group",
                                 description="vertex group of the lattice: weight 1 keeps a point where you put it, "
                                             "0 lets it take its full share of the correction")
    targets: CollectionProperty(type=VPFFD_Target)
    live: BoolProperty(name="Live", default=False, update=_live_changed,
                       description="re-evaluate whenever the lattice, the targets or the frame change")
    bake_start: IntProperty(name="Start", default=1)
    bake_end: IntProperty(name="End", default=250)
    volume_rest: FloatProperty(name="Rest volume", default=float("nan"))
    volume_plain: FloatProperty(name="Plain FFD volume", default=float("nan"))
    volume_after: FloatProperty(name="Volume", default=float("nan"))
    fold_verdict: StringProperty(name="Folds", default="")


# Runtime only (never saved): the embedded mesh and the last state per live object,
# so that dragging a lattice point costs one frame, not a re-embedding.
_caches: dict = {}


def _settings(obj):
    return obj.vpffd


def _pick_lattice(context, obj):
    """The settings' lattice, else the one other selected lattice object (not stored until success)."""
    s = _settings(obj)
    if s.lattice is not None:
        return s.lattice
    lats = [o for o in context.selected_objects if o.type == 'LATTICE']
    return lats[0] if len(lats) == 1 else None


class _With:
    """Settings with the lattice substituted, for an evaluation before anything is stored."""

    def __init__(self, settings, lattice):
        self._s, self.lattice = settings, lattice

    def __getattr__(self, name):
        return getattr(self._s, name)


class _OnMesh:
    """The operators act on the active object, which must be a mesh."""

    @classmethod
    def poll(cls, context):
        return context.active_object is not None and context.active_object.type == 'MESH'


class VPFFD_OT_deform(_OnMesh, bpy.types.Operator):
    """Deform the active mesh by a lattice, keeping its volume exact (vpffd)"""
    bl_idname = "object.vpffd_lattice"
    bl_label = "Volume-preserving lattice"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        obj = context.active_object
        s = _settings(obj)
        lat = _pick_lattice(context, obj)
        try:
            ev = engine.evaluate(obj, _With(s, lat))
        except engine.Refused as e:
            self.report({'ERROR'}, str(e))
            return {'CANCELLED'}
        if s.lattice is None:
            s.lattice = lat
        engine.apply(obj, s, ev)
        # What live mode would compute for this state is already there (and exactly rounded):
        # the next depsgraph update must not overwrite it.
        _caches.setdefault(obj.name_full, engine.Cache()).state = engine.state_signature(obj, s)
        for n in ev.notes:
            self.report({'INFO'}, n)
        rest, plain, after = ev.volumes
        self.report({'INFO'}, f"volume {after:.6g} (rest {rest:.6g}, plain FFD {plain:.6g})")
        return {'FINISHED'}


class VPFFD_OT_bake(_OnMesh, bpy.types.Operator):
    """Bake one shape key per frame (vpffd_0001, ...), each keyed to 1 on its own frame"""
    bl_idname = "object.vpffd_bake"
    bl_label = "Bake shape keys"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        obj, scene = context.active_object, context.scene
        s = _settings(obj)
        lat = _pick_lattice(context, obj)
        if s.bake_end < s.bake_start:
            self.report({'ERROR'}, f"bake range {s.bake_start}..{s.bake_end} is empty")
            return {'CANCELLED'}
        frame0, sub0 = scene.frame_current, scene.frame_subframe
        frames, evs, cache = range(s.bake_start, s.bake_end + 1), [], engine.Cache()
        _suspended.add(obj.name_full)
        try:
            for f in frames:
                scene.frame_set(f)
                evs.append(engine.evaluate(obj, _With(s, lat), cache))
        except engine.Refused as e:
            self.report({'ERROR'}, f"frame {f}: {e}")
            return {'CANCELLED'}
        finally:
            scene.frame_set(frame0, subframe=sub0)
            _suspended.discard(obj.name_full)
        if s.lattice is None:
            s.lattice = lat
        if evs[0].snap:
            engine.write_lattice(s.lattice, evs[0])
        s.live = False
        keys = obj.data.shape_keys
        if keys is not None and keys.key_blocks.get(engine.LIVE_KEY) is not None:
            obj.shape_key_remove(keys.key_blocks[engine.LIVE_KEY])
        for f, ev in zip(frames, evs):
            kb = engine.write_shape_key(obj, f"{engine.BAKE_PREFIX}{f:04d}", ev.key)
            for g, v in ((f - 1, 0.0), (f, 1.0), (f + 1, 0.0)):
                kb.value = v
                kb.keyframe_insert("value", frame=g)
            kb.value = 1.0 if f == frame0 else 0.0
        engine.write_figures(s, evs[-1])
        worst = max(abs(e.result.volume - e.result.rest_volume) / abs(e.result.rest_volume) for e in evs) \
            if s.preserve_volume else float("nan")
        self.report({'INFO'}, f"baked {len(evs)} shape keys ({frames[0]}..{frames[-1]}); largest relative volume "
                              f"error {worst:.2e}")
        return {'FINISHED'}


class VPFFD_OT_add_targets(_OnMesh, bpy.types.Operator):
    """Add an empty at each selected vertex; moving the empty drags that vertex (vpffd point constraint)"""
    bl_idname = "object.vpffd_add_targets"
    bl_label = "Add targets at selected vertices"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        obj = context.active_object
        if obj.mode == 'EDIT':
            obj.update_from_editmode()
        me = obj.data
        sel = np.zeros(len(me.vertices), dtype=bool)
        me.vertices.foreach_get("select", sel)
        idx = np.flatnonzero(sel)
        if len(idx) == 0:
            self.report({'ERROR'}, "select the vertices to drag first (edit mode)")
            return {'CANCELLED'}
        if len(idx) > 64:
            self.report({'ERROR'}, f"{len(idx)} vertices selected; targets are meant for a few dragged points (<= 64)")
            return {'CANCELLED'}
        rest, _, _ = engine.read_mesh(obj)
        M = np.array(obj.matrix_world, dtype=np.float64)
        for i in idx:
            e = bpy.data.objects.new(f"{obj.name}_target_{i}", None)
            e.empty_display_type = 'SPHERE'
            e.empty_display_size = 0.05 * max(obj.dimensions) if max(obj.dimensions) > 0 else 0.05
            e.location = (M[:3, :3] @ rest[i] + M[:3, 3]).tolist()
            context.collection.objects.link(e)
            t = _settings(obj).targets.add()
            t.empty, t.vertex = e, int(i)
        self.report({'INFO'}, f"added {len(idx)} target empties")
        return {'FINISHED'}


class VPFFD_OT_remove_target(bpy.types.Operator):
    """Remove a target (the empty itself is kept)"""
    bl_idname = "object.vpffd_remove_target"
    bl_label = "Remove target"
    bl_options = {'REGISTER', 'UNDO'}
    index: IntProperty()

    def execute(self, context):
        t = _settings(context.active_object).targets
        if not 0 <= self.index < len(t):
            self.report({'ERROR'}, f"no target {self.index}")
            return {'CANCELLED'}
        t.remove(self.index)
        return {'FINISHED'}


class VPFFD_PT_panel(bpy.types.Panel):
    bl_label = "Volume-preserving lattice"
    bl_idname = "VPFFD_PT_panel"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "vpffd"

    def draw(self, context):
        col = self.layout.column()
        try:
            engine.import_vpffd()
        except engine.Refused as e:
            for i, line in enumerate(_wrap(str(e), 48)):
                col.label(text=line, icon='ERROR' if i == 0 else 'NONE')
            return
        obj = context.active_object
        if obj is None or obj.type != 'MESH':
            col.label(text="Select a mesh (and a lattice)")
            return
        s = _settings(obj)
        col.prop(s, "lattice")
        col.prop(s, "preserve_volume")
        if s.preserve_volume:
            col.prop(s, "exact_float32")
        col.prop(s, "axes")
        col.prop(s, "degree")
        if s.lattice is not None:
            col.prop_search(s, "weight_group", s.lattice, "vertex_groups")
        box = col.box()
        box.label(text="Dragged points")
        for i, t in enumerate(s.targets):
            row = box.row()
            row.prop(t, "empty", text="")
            row.prop(t, "vertex", text="v")
            row.operator(VPFFD_OT_remove_target.bl_idname, text="", icon='X').index = i
        box.operator(VPFFD_OT_add_targets.bl_idname, icon='EMPTY_AXIS')
        col.operator(VPFFD_OT_deform.bl_idname, icon='MOD_LATTICE')
        col.prop(s, "live", toggle=True)
        row = col.row(align=True)
        row.prop(s, "bake_start")
        row.prop(s, "bake_end")
        col.operator(VPFFD_OT_bake.bl_idname, icon='SHAPEKEY_DATA')
        if s.volume_rest == s.volume_rest:  # not NaN: evaluated at least once
            res = col.box()
            res.label(text=f"Rest volume: {s.volume_rest:.6g}")
            res.label(text=f"Plain FFD: {s.volume_plain:.6g} ({_pct(s.volume_plain, s.volume_rest)})")
            res.label(text=f"vpffd: {s.volume_after:.6g} ({_pct(s.volume_after, s.volume_rest)})")
            if s.fold_verdict:
                res.label(text=f"Folds: {s.fold_verdict}")
        c = _caches.get(obj.name_full)
        if c is not None and c.error:
            for line in _wrap(c.error, 48):
                col.label(text=line)


def _pct(v, ref):
    return f"{100.0 * (v - ref) / ref:+.4g} %" if ref else "n/a"


def _wrap(text, width):
    words, lines, cur = text.split(), [], ""
    for w in words:
        if cur and len(cur) + 1 + len(w) > width:
            lines.append(cur)
            cur = w
        else:
            cur = f"{cur} {w}".strip()
    return lines + ([cur] if cur else [])


# --- live updates ------------------------------------------------------------------
_suspended: set = set()
# The last live update's time per object, in seconds (for measuring; read by the tests).
last_update_seconds: dict = {}


def update_live(scene) -> int:
    """Re-evaluates every live mesh object of ``scene`` whose inputs changed; returns how many were updated."""
    n = 0
    for obj in scene.objects:
        if obj.type != 'MESH' or obj.name_full in _suspended:
            continue
        s = obj.vpffd
        if not s.live or s.lattice is None:
            continue
        c = _caches.setdefault(obj.name_full, engine.Cache())
        t0 = time.perf_counter()
        state = engine.state_signature(obj, s)
        if state == c.state:
            continue
        c.state = state  # also after a refusal: the same input would be refused again
        try:
            ev = engine.evaluate(obj, s, c, exact_float32=False)
        except engine.Refused as e:
            c.error = str(e)
            continue
        c.error = ""
        engine.apply(obj, s, ev)
        if ev.snap:  # the points were rewritten; what we read next time is what we wrote
            c.state = engine.state_signature(obj, s)
        last_update_seconds[obj.name_full] = time.perf_counter() - t0
        n += 1
    return n


@persistent
def _on_depsgraph(scene, depsgraph=None):
    update_live(scene)


@persistent
def _on_frame(scene, depsgraph=None):
    update_live(scene)


classes = (VPFFD_Target, VPFFD_Settings, VPFFD_OT_deform, VPFFD_OT_bake, VPFFD_OT_add_targets,
           VPFFD_OT_remove_target, VPFFD_PT_panel)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Object.vpffd = PointerProperty(type=VPFFD_Settings)
    bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph)
    bpy.app.handlers.frame_change_post.append(_on_frame)


def unregister():
    for h, f in ((bpy.app.handlers.depsgraph_update_post, _on_depsgraph),
                 (bpy.app.handlers.frame_change_post, _on_frame)):
        if f in h:
            h.remove(f)
    del bpy.types.Object.vpffd
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
    _caches.clear()
    _suspended.clear()
    last_update_seconds.clear()
