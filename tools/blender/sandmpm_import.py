"""Blender add-on: import a sandmpm run folder as an animated point cloud.

What it builds (Blender 3.4, its own Python API; no other module than NumPy, which Blender ships):
  - one mesh object "sandmpm: FOLDER" whose vertices are the particles of the frame shown: on every
    frame change the matching frame file is read (the scene's frame_start shows frame_0000.ply,
    each later frame the next file, clamped to the last one; the frames the folder's
    run_manifest.txt lists, or every frame_NNNN.ply of a folder without one) and the mesh is rebuilt, so runs whose
    particle count grows (emitters) work as well;
  - every per-particle property of the PLY file as a named point attribute: velocity (vector, the
    file's vx vy vz), q, material, friction_angle, Je, volume, id when the file has it, and radius
    (the radius of a sphere, or in 2D a disk, of the particle's volume) for rendering;
  - y-up (sandmpm, the thesis) to z-up (Blender): (x, y, z) -> (x, -z, y), for positions and
    velocities; off with z_up=False; frames a run wrote z-up (outputs.up = "z", "comment up z")
    are recognised and not turned twice;
  - a geometry-nodes modifier that instances an icosphere of the particle's radius on every vertex
    (scaled by radius_scale), with one material, so the cloud renders in Eevee and Cycles.

Use, in Blender: Edit > Preferences > Add-ons > Install... (this file), enable "Import: sandmpm
run", then File > Import > sandmpm run (folder). From a script or the command line:
    blender --background --python tools/blender/sandmpm_import.py -- OUT_DIR [--save FILE.blend]
imports OUT_DIR (a folder written by `sandmpm run --out OUT_DIR`) and optionally saves the scene.

The PLY reader below reads what sandmpm writes (binary little/big endian or ascii, any scalar
types, properties found by name) and refuses other files with a message.
"""

import math
import os
import re
import sys

import numpy as np

try:
    import bpy
    from bpy.props import BoolProperty, FloatProperty, StringProperty
    from bpy_extras.io_utils import ImportHelper
except ImportError:  # the PLY reader is usable (and testable) without Blender
    bpy = None

bl_info = {
    "name": "Import: sandmpm run",
    "author": "sandmpm",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "File > Import > sandmpm run (folder)",
    "description": "Imports a sandmpm output folder as an animated point cloud with every particle attribute",
    "category": "Import-Export",
}

# ---------------------------------------------------------------------------------------------
# PLY frames

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


class PlyError(ValueError):
    pass


def _parse_header(data, path):
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise PlyError(f"{path}: not a PLY file")
    nl = data.find(b"\n", end)
    if nl < 0:
        raise PlyError(f"{path}: header without a line end")
    lines = data[:end].decode("ascii", "replace").splitlines()
    fmt, comments, elements = None, [], []
    for line in lines[1:]:
        w = line.split()
        if not w:
            continue
        if w[0] == "format" and len(w) >= 2:
            fmt = w[1]
        elif w[0] == "comment":
            comments.append(line[len("comment"):].strip())
        elif w[0] == "element" and len(w) == 3:
            elements.append([w[1], int(w[2]), []])
        elif w[0] == "property" and elements:
            if w[1] == "list":
                raise PlyError(f"{path}: list properties are not sandmpm frames")
            if w[1] not in _PLY_TYPES or len(w) != 3:
                raise PlyError(f"{path}: unsupported property line '{line}'")
            elements[-1][2].append((w[2], _PLY_TYPES[w[1]]))
    if fmt not in ("binary_little_endian", "binary_big_endian", "ascii"):
        raise PlyError(f"{path}: unsupported format {fmt}")
    return fmt, comments, elements, nl + 1


def read_ply(path):
    """Returns (fields, comments): fields maps a property name to a NumPy array (one value per
    vertex), comments is the list of header comments."""
    with open(path, "rb") as f:
        data = f.read()
    fmt, comments, elements, off = _parse_header(data, path)
    order = "<" if fmt == "binary_little_endian" else ">"
    text_rows = data[off:].decode("ascii", "replace").split("\n") if fmt == "ascii" else None
    row = 0
    for name, count, props in elements:
        if fmt == "ascii":
            block = text_rows[row:row + count]
            row += count
            if name != "vertex":
                continue
            if len(block) < count:
                raise PlyError(f"{path}: truncated ({len(block)} of {count} vertices)")
            vals = np.array([ln.split()[:len(props)] for ln in block], dtype=np.float64).reshape(count, len(props))
            return {p: vals[:, k].astype(t) for k, (p, t) in enumerate(props)}, comments
        dt = np.dtype([(p, order + t) for p, t in props])
        size = dt.itemsize * count
        if name == "vertex":
            if off + size > len(data):
                raise PlyError(f"{path}: truncated ({len(data) - off} of {size} vertex bytes)")
            rec = np.frombuffer(data, dtype=dt, count=count, offset=off)
            return {p: rec[p].astype(rec[p].dtype.newbyteorder("=")) for p, _ in props}, comments
        off += size
    raise PlyError(f"{path}: no vertex element")


def manifest_frames(folder):
    """(first, last) of the PLY frames that the folder's run_manifest.txt lists (docs/outputs.md),
    or None if the folder has no manifest or it lists no PLY frames."""
    try:
        with open(os.path.join(folder, "run_manifest.txt")) as f:
            lines = f.read().splitlines()
    except OSError:
        return None
    for line in lines[1:] if lines and lines[0] == "sandmpm-run 1" else []:
        w = line.split()
        if len(w) == 4 and w[0] == "frame_files" and w[1] == "ply":
            return int(w[2]), int(w[3])
    return None


def frame_files(folder):
    """The run's frame files in frame order: those its run_manifest.txt lists (so that files of
    another run in the folder are not mixed in), or every frame_NNNN.ply of a folder without one."""
    listed = manifest_frames(folder)
    if listed:
        names = [f"frame_{k:04d}.ply" for k in range(listed[0], listed[1] + 1)]
        return [os.path.join(folder, n) for n in names if os.path.exists(os.path.join(folder, n))]
    names = [n for n in os.listdir(folder) if re.fullmatch(r"frame_\d+\.ply", n)]
    if not names:
        raise PlyError(f"{folder}: no frame_NNNN.ply files (is this a `sandmpm run --out` folder?)")
    return [os.path.join(folder, n) for n in sorted(names, key=lambda n: int(n[6:-4]))]


def run_dim(comments, fields):
    for c in comments:
        w = c.split()
        if len(w) == 2 and w[0] == "dim" and w[1] in ("2", "3"):
            return int(w[1])
    return 3 if "z" in fields and np.any(fields["z"] != 0) else 2


def particle_radius(volume, dim):
    """Radius of a sphere (3D) or a disk (2D) of the particle's volume (area in 2D)."""
    v = np.maximum(volume.astype(np.float64), 0.0)
    if dim == 3:
        return np.cbrt(3.0 * v / (4.0 * math.pi))
    return np.sqrt(v / math.pi)


def to_blender_axes(x, y, z, z_up, file_z_up=False):
    """sandmpm's y-up coordinates to Blender's z-up: (x, y, z) -> (x, -z, y). A frame written z-up
    (scene outputs.up = "z", header "comment up z") is first turned back: (X, Y, Z) -> (X, Z, -Y)."""
    if file_z_up:
        x, y, z = x, z, -y
    if not z_up:
        return x, y, z
    return x, -z, y


def frame_arrays(path, z_up=True):
    """Everything one frame puts on the mesh: positions (n x 3) and point attributes
    {name: (Blender type, values)}."""
    f, comments = read_ply(path)
    for k in ("x", "y"):
        if k not in f:
            raise PlyError(f"{path}: no '{k}' property")
    n = len(f["x"])
    zero = np.zeros(n, dtype=np.float32)
    dim = run_dim(comments, f)
    file_z = "up z" in comments
    pos = np.stack(to_blender_axes(f["x"], f["y"], f.get("z", zero), z_up, file_z), axis=1).astype(np.float32)
    attrs = {}
    if "vx" in f:
        vel = to_blender_axes(f["vx"], f["vy"], f.get("vz", zero), z_up, file_z)
        attrs["velocity"] = ("FLOAT_VECTOR", np.stack(vel, axis=1).astype(np.float32))
    for name, values in f.items():
        if name in ("x", "y", "z", "vx", "vy", "vz"):
            continue
        kind = "INT" if np.issubdtype(values.dtype, np.integer) else "FLOAT"
        attrs[name] = (kind, values.astype(np.int32 if kind == "INT" else np.float32))
    if "volume" in f:
        attrs["radius"] = ("FLOAT", particle_radius(f["volume"], dim).astype(np.float32))
    return pos, attrs


# ---------------------------------------------------------------------------------------------
# Blender side

def _fill_mesh(mesh, pos, attrs):
    mesh.clear_geometry()
    mesh.vertices.add(len(pos))
    mesh.vertices.foreach_set("co", pos.ravel())
    for name, (kind, values) in attrs.items():
        a = mesh.attributes.get(name) or mesh.attributes.new(name, kind, "POINT")
        key = "vector" if kind == "FLOAT_VECTOR" else "value"
        a.data.foreach_set(key, values.ravel())
    mesh.update()


def _shown_file(obj, frame):
    files = obj["sandmpm_files"]
    k = frame - obj["sandmpm_start"]
    return files[min(max(k, 0), len(files) - 1)]


def _on_frame_change(scene, _depsgraph=None):
    for obj in scene.objects:
        if "sandmpm_files" not in obj or obj.type != "MESH":
            continue
        path = _shown_file(obj, scene.frame_current)
        if obj.get("sandmpm_loaded") == path:
            continue
        pos, attrs = frame_arrays(path, bool(obj["sandmpm_z_up"]))
        _fill_mesh(obj.data, pos, attrs)
        obj["sandmpm_loaded"] = path


def _sphere_nodes(obj, radius_scale, material):
    """Geometry nodes: an icosphere of the particle's radius on every vertex."""
    tree = bpy.data.node_groups.new("sandmpm spheres", "GeometryNodeTree")
    tree.inputs.new("NodeSocketGeometry", "Geometry")
    tree.outputs.new("NodeSocketGeometry", "Geometry")
    nodes, links = tree.nodes, tree.links
    gin, gout = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    to_points = nodes.new("GeometryNodeMeshToPoints")
    sphere = nodes.new("GeometryNodeMeshIcoSphere")
    sphere.inputs["Radius"].default_value = 1.0
    sphere.inputs["Subdivisions"].default_value = 1
    radius = nodes.new("GeometryNodeInputNamedAttribute")
    radius.data_type = "FLOAT"
    radius.inputs["Name"].default_value = "radius"
    scale = nodes.new("ShaderNodeMath")
    scale.operation = "MULTIPLY"
    scale.inputs[1].default_value = radius_scale
    inst = nodes.new("GeometryNodeInstanceOnPoints")
    setmat = nodes.new("GeometryNodeSetMaterial")
    setmat.inputs["Material"].default_value = material
    links.new(gin.outputs["Geometry"], to_points.inputs["Mesh"])
    links.new(to_points.outputs["Points"], inst.inputs["Points"])
    links.new(sphere.outputs["Mesh"], inst.inputs["Instance"])
    links.new(radius.outputs["Attribute"], scale.inputs[0])
    links.new(scale.outputs["Value"], inst.inputs["Scale"])
    links.new(inst.outputs["Instances"], setmat.inputs["Geometry"])
    links.new(setmat.outputs["Geometry"], gout.inputs["Geometry"])
    mod = obj.modifiers.new("sandmpm spheres", "NODES")
    mod.node_group = tree
    return mod


def _sand_material():
    mat = bpy.data.materials.get("sandmpm sand") or bpy.data.materials.new("sandmpm sand")
    mat.diffuse_color = (0.76, 0.62, 0.42, 1.0)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    if bsdf:
        bsdf.inputs["Base Color"].default_value = (0.76, 0.62, 0.42, 1.0)
        bsdf.inputs["Roughness"].default_value = 0.9
    return mat


def import_run(folder, z_up=True, spheres=True, radius_scale=1.0, context=None):
    """Imports a run folder; returns the new object. The scene's frame range becomes the run's."""
    context = context or bpy.context
    folder = os.path.abspath(folder)
    files = frame_files(folder)
    name = "sandmpm: " + os.path.basename(folder.rstrip("/"))
    mesh = bpy.data.meshes.new(name)
    obj = bpy.data.objects.new(name, mesh)
    context.scene.collection.objects.link(obj)
    scene = context.scene
    obj["sandmpm_files"] = files
    obj["sandmpm_start"] = scene.frame_start
    obj["sandmpm_z_up"] = int(z_up)
    scene.frame_end = scene.frame_start + len(files) - 1
    pos, attrs = frame_arrays(_shown_file(obj, scene.frame_current), z_up)
    _fill_mesh(mesh, pos, attrs)
    obj["sandmpm_loaded"] = _shown_file(obj, scene.frame_current)
    if spheres:
        _sphere_nodes(obj, radius_scale, _sand_material())
    if _on_frame_change not in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.append(_on_frame_change)
    return obj


if bpy is not None:
    class IMPORT_OT_sandmpm_run(bpy.types.Operator, ImportHelper):
        """Import a sandmpm output folder as an animated point cloud"""
        bl_idname = "import_scene.sandmpm_run"
        bl_label = "Import sandmpm run"
        bl_options = {"REGISTER", "UNDO"}
        filename_ext = ""
        use_filter_folder = True
        directory: StringProperty(subtype="DIR_PATH")
        z_up: BoolProperty(name="Z up", description="Turn sandmpm's y-up data to Blender's z-up", default=True)
        spheres: BoolProperty(name="Spheres", description="Instance a sphere of the particle's radius on each point",
                              default=True)
        radius_scale: FloatProperty(name="Radius scale", default=1.0, min=0.01, max=100.0)

        def execute(self, context):
            try:
                import_run(self.directory, self.z_up, self.spheres, self.radius_scale, context)
            except (OSError, PlyError) as e:
                self.report({"ERROR"}, str(e))
                return {"CANCELLED"}
            return {"FINISHED"}

    def _menu(self, _context):
        self.layout.operator(IMPORT_OT_sandmpm_run.bl_idname, text="sandmpm run (folder)")


def register():
    bpy.utils.register_class(IMPORT_OT_sandmpm_run)
    bpy.types.TOPBAR_MT_file_import.append(_menu)
    if _on_frame_change not in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.append(_on_frame_change)


def unregister():
    bpy.types.TOPBAR_MT_file_import.remove(_menu)
    bpy.utils.unregister_class(IMPORT_OT_sandmpm_run)
    if _on_frame_change in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.remove(_on_frame_change)


def _main(argv):
    """blender --background --python sandmpm_import.py -- OUT_DIR [--save FILE.blend] [--y-up]"""
    args = argv[argv.index("--") + 1:] if "--" in argv else []
    if not args:
        print("usage: blender --background --python sandmpm_import.py -- OUT_DIR [--save FILE.blend] [--y-up]")
        return 2
    save = args[args.index("--save") + 1] if "--save" in args else None
    obj = import_run(args[0], z_up="--y-up" not in args)
    print(f"sandmpm_import: {obj.name}: {len(obj.data.vertices)} particles, {len(obj['sandmpm_files'])} frames")
    if save:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(save))
    return 0


if __name__ == "__main__" and bpy is not None and "--" in sys.argv:
    _main(sys.argv)
