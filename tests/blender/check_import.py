"""Runs inside Blender (background): imports a run folder with tools/blender/sandmpm_import.py and
checks the point cloud against the PLY files: vertex count, every attribute, y-up -> z-up, a frame
change loading the next frame, stable ids (vertex k is id k), the sphere modifier. Exit status 1 on the first failure.
    blender --background --factory-startup --python tests/blender/check_import.py -- OUT_DIR"""
import os
import sys

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tools", "blender"))
import sandmpm_import as si  # noqa: E402

failed = 0


def check(cond, what):
    global failed
    print(("ok: " if cond else "FAIL: ") + what)
    failed += 0 if cond else 1


def mesh_positions(obj):
    co = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
    obj.data.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


folder = sys.argv[sys.argv.index("--") + 1]
files = si.frame_files(folder)
check(len(files) >= 2, f"the run has {len(files)} frames (need 2)")
scene = bpy.context.scene
scene.frame_set(scene.frame_start)
obj = si.import_run(folder)
f0, _ = si.read_ply(files[0])
check(len(obj.data.vertices) == len(f0["x"]), f"{len(obj.data.vertices)} vertices = {len(f0['x'])} particles of frame 0")
names = set(obj.data.attributes.keys())
want = {"velocity", "q", "material", "Je", "volume", "friction_angle", "radius"} | ({"id"} if "id" in f0 else set())
check(want <= names, f"attributes {sorted(want)} present (have {sorted(names)})")
pos = mesh_positions(obj)
check(np.allclose(pos[:, 2], f0["y"], atol=1e-6), "Blender z is sandmpm y (z up)")
check(np.allclose(pos[:, 1], -f0["z"], atol=1e-6), "Blender y is -sandmpm z")
check(scene.frame_end - scene.frame_start + 1 == len(files), "the scene's frame range is the run's")
check(any(m.type == "NODES" for m in obj.modifiers), "a geometry-nodes sphere modifier")
scene.frame_set(scene.frame_start + 1)
f1, _ = si.read_ply(files[1])
pos1 = mesh_positions(obj)
check(len(pos1) == len(f1["x"]) and np.allclose(pos1[:, 2], f1["y"], atol=1e-6), "a frame change loads frame 1")
check(len(pos1) != len(pos) or not np.allclose(pos1, pos), "frame 1 differs from frame 0 (the sand moved)")
v = np.empty(len(pos1) * 3, dtype=np.float32)
obj.data.attributes["velocity"].data.foreach_get("vector", v)
check(np.allclose(v.reshape(-1, 3)[:, 2], f1["vy"], atol=1e-6), "velocity attribute of frame 1, z up")
# stable ids: vertex k is the grain with id k in every frame (no emitter in the default scene)
ids = np.empty(len(pos1), dtype=np.int32)
obj.data.attributes["id"].data.foreach_get("value", ids)
check("id" in f0 and np.array_equal(ids, np.arange(len(pos1))), "the id attribute of frame 1 is the vertex index")
dg = bpy.context.evaluated_depsgraph_get()
spheres = sum(1 for i in dg.object_instances if i.is_instance and i.parent and i.parent.original == obj)
check(spheres == len(pos1), f"{spheres} sphere instances, one per particle")
print(f"check_import: {failed} failed")
sys.exit(1 if failed else 0)
