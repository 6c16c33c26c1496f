"""Blender's Lattice modifier, timed: the peer side of bench_peers.py.

Runs inside the peers virtual environment (Python 3.11 with the ``bpy`` wheel),
in its own process, started by bench_peers.py as

    .venv-peers/bin/python bench/python/_blender_lattice.py MESH.npz CPUS

MESH.npz holds the mesh (V, F), the lattice box (box_min, box_max), the lattice
size (shape) and the edited lattice points in Blender's point order (u fastest),
in world coordinates. CPUS ("0,1") is the set of CPUs the process may run on,
set before Blender starts, so its task scheduler has exactly those cores.

It builds the mesh object, a B-spline lattice object over the box and a Lattice
modifier, then answers commands on stdin, one JSON line each on stdout:
  "time R"  ->  {"modifier_ms": [...], "base_ms": [...]}: R evaluations of the
               mesh object with the modifier, then R with it disabled (the cost
               of re-evaluating the object without any deformation)
  "quit"
"""
import json
import os
import sys
import time


def main():
    path, cpus = sys.argv[1], [int(c) for c in sys.argv[2].split(",")]
    os.sched_setaffinity(0, cpus)
    import numpy as np
    import bpy

    d = np.load(path)
    V, F = d["V"], d["F"]
    box_min, box_max = d["box_min"], d["box_max"]
    nu, nv, nw = (int(x) for x in d["shape"])
    edited = d["edited_points"]  # (nu nv nw, 3) world, u fastest

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene

    mesh = bpy.data.meshes.new("mesh")
    mesh.vertices.add(len(V))
    mesh.vertices.foreach_set("co", V.astype(np.float32).ravel())
    mesh.loops.add(3 * len(F))
    mesh.loops.foreach_set("vertex_index", F.astype(np.int32).ravel())
    mesh.polygons.add(len(F))
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(F), 3, dtype=np.int32))
    mesh.update()
    obj = bpy.data.objects.new("mesh", mesh)
    scene.collection.objects.link(obj)

    lat = bpy.data.lattices.new("lattice")
    lat.points_u, lat.points_v, lat.points_w = nu, nv, nw
    lat.interpolation_type_u = lat.interpolation_type_v = lat.interpolation_type_w = "KEY_BSPLINE"
    lat.use_outside = False
    lat_obj = bpy.data.objects.new("lattice", lat)
    scene.collection.objects.link(lat_obj)
    # The lattice object's transform maps its rest points (a uniform grid in
    # local space) onto the box.
    rest = np.empty(3 * len(lat.points))
    lat.points.foreach_get("co", rest)
    rest = rest.reshape(-1, 3)
    lo, hi = rest.min(axis=0), rest.max(axis=0)
    scale = (box_max - box_min) / (hi - lo)
    loc = 0.5 * (box_min + box_max) - scale * 0.5 * (lo + hi)
    lat_obj.scale = scale.tolist()
    lat_obj.location = loc.tolist()
    world_rest = loc + scale * rest
    expect = np.stack(np.meshgrid(*[np.linspace(box_min[a], box_max[a], n) for a, n in enumerate((nu, nv, nw))],
                                  indexing="ij"), axis=-1).transpose(2, 1, 0, 3).reshape(-1, 3)
    err = np.abs(world_rest - expect).max()
    if err > 1e-6 * np.abs(box_max - box_min).max():
        raise SystemExit(f"blender: lattice point order or rest grid not as expected (error {err})")
    lat.points.foreach_set("co_deform", ((edited - loc) / scale).ravel())

    mod = obj.modifiers.new("lattice", "LATTICE")
    mod.object = lat_obj
    dg = bpy.context.evaluated_depsgraph_get()

    def evaluate():
        obj.update_tag(refresh={"DATA"})  # re-runs the object's modifier stack
        dg.update()

    evaluate()
    out = np.empty(3 * len(V), np.float32)
    obj.evaluated_get(dg).data.vertices.foreach_get("co", out)
    moved = float(np.abs(out.reshape(-1, 3) - V).max())
    info = dict(version=bpy.app.version_string, vertices=len(V), moved=moved,
                threads_in_process=len(os.listdir("/proc/self/task")), cpus=cpus)
    print(json.dumps(info), flush=True)

    for line in sys.stdin:
        cmd = line.split()
        if not cmd or cmd[0] == "quit":
            break
        repeats = int(cmd[1])
        res = {}
        for key, show in (("modifier_ms", True), ("base_ms", False)):
            mod.show_viewport = show
            evaluate()  # warm-up
            t = []
            for _ in range(repeats):
                s = time.perf_counter()
                evaluate()
                t.append(1e3 * (time.perf_counter() - s))
            res[key] = t
        mod.show_viewport = True
        print(json.dumps(res), flush=True)


if __name__ == "__main__":
    main()
