"""Imports a ccfr run into Blender as animated meshes, without add-ons.

    blender -b --python scripts/import_blender.py -- RUN_DIR [--z-up] [--save OUT.blend] [--keep-scene]

`-b` runs Blender without a window (a machine without a display needs it: without it Blender
stops with "GHOST: unable to initialize"); on a desktop, leave it out to get the imported scene
in Blender's window.

RUN_DIR must hold blender/ (written by `output.formats: [pc2]` or `ccfr export RUN_DIR --format pc2`):
first_frame.obj, one .pc2 point cache per object and manifest.json. The scene's objects (the
startup file's cube, light and camera) are removed first, unless --keep-scene. Each object becomes
a mesh built from the first frame in ccfr's vertex order (faces, strand edges, loose particle
vertices), with a Mesh Cache modifier (PC2) that plays the run: Blender frame F shows ccfr frame F.
The scene's fps and frame range (frame_start, frame_end) follow the run. --z-up rotates the objects
(not their vertices) from ccfr's y-up to Blender's z-up. --save writes a .blend whose point caches
are referenced relative to it (move the .blend and the run together).
"""
import argparse
import json
import math
import os
import sys

import bpy


def read_obj(path):
    """Vertices, faces, lines and points of a ccfr frame (0-based global indices)."""
    v, blocks = [], []
    with open(path) as f:
        for line in f:
            t = line.split()
            if not t or t[0].startswith("#"):
                continue
            if t[0] == "o":
                blocks.append({"name": line[2:].rstrip("\n"), "f": [], "l": [], "p": []})
            elif t[0] == "v":
                v.append(tuple(float(c) for c in t[1:4]))
            elif t[0] in ("f", "l", "p"):
                blocks[-1][t[0]].append([int(i.split("/")[0]) - 1 for i in t[1:]])
    return v, blocks


def clear_scene():
    """Removes every object (the startup file's cube, light, camera) and the data they leave unused."""
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)
    for coll in (bpy.data.meshes, bpy.data.lights, bpy.data.cameras, bpy.data.materials):
        for block in list(coll):
            if block.users == 0:
                coll.remove(block)


def import_run(run_dir, z_up=False):
    bdir = os.path.join(run_dir, "blender")
    manifest_path = os.path.join(bdir, "manifest.json")
    if not os.path.exists(manifest_path):
        raise FileNotFoundError(
            "%s does not exist: write the run with output.formats including pc2, or run "
            "`ccfr export %s --format pc2`" % (manifest_path, run_dir))
    with open(manifest_path) as f:
        manifest = json.load(f)
    verts, blocks = read_obj(os.path.join(bdir, manifest["first_frame"]))
    every = max(1, int(manifest["every"]))
    scene = bpy.context.scene
    fps = float(manifest["fps"])
    # Blender's frame rate is the integer fps / fps_base: exact for non-integer rates too.
    scene.render.fps = max(1, round(fps))
    scene.render.fps_base = scene.render.fps / fps
    scene.frame_start = int(manifest["start_frame"])
    last = int(manifest["start_frame"])
    objects = []
    for entry, block in zip(manifest["objects"], blocks):
        b, e = entry["vertex_begin"], entry["vertex_end"]
        local = [verts[i] for i in range(b, e)]
        faces = [[i - b for i in poly] for poly in block["f"]]
        edges = []
        for line in block["l"]:
            edges += [(line[k] - b, line[k + 1] - b) for k in range(len(line) - 1)]
        mesh = bpy.data.meshes.new(entry["name"])
        mesh.from_pydata(local, edges, faces)
        mesh.update()
        obj = bpy.data.objects.new(entry["name"], mesh)
        if z_up:
            obj.rotation_euler = (math.pi / 2, 0.0, 0.0)
        mod = obj.modifiers.new("ccfr", "MESH_CACHE")
        mod.cache_format = "PC2"
        mod.filepath = os.path.abspath(os.path.join(bdir, entry["pc2"]))
        mod.time_mode = "FRAME"
        mod.play_mode = "SCENE"
        mod.interpolation = "LINEAR"
        mod.forward_axis = "POS_Y"
        mod.up_axis = "POS_Z"
        # Sample index = frame_scale * frame - frame_start: Blender frame F shows ccfr frame F.
        mod.frame_scale = 1.0 / every
        mod.frame_start = manifest["start_frame"] / every
        with open(mod.filepath, "rb") as pc2:
            samples = int.from_bytes(pc2.read(32)[28:32], "little")
        last = max(last, int(manifest["start_frame"]) + (samples - 1) * every)
        # Linked once its modifier has a file: a linked object is evaluated at once, and a Mesh
        # Cache without one printed "No such file or directory".
        scene.collection.objects.link(obj)
        objects.append(obj)
    scene.frame_end = last
    scene.frame_set(scene.frame_start)
    return objects


def save_blend(path, objects):
    """Saves the scene as PATH, the point caches referenced relative to it ('//' paths)."""
    path = os.path.abspath(path)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    # Blender remaps the absolute paths to '//' ones as it saves; set by hand before the file had
    # a path, they resolved against nothing and the modifiers printed "No such file or directory".
    bpy.ops.wm.save_as_mainfile(filepath=path, check_existing=False, relative_remap=True)
    bad = [o.name for o in objects for m in o.modifiers if m.type == "MESH_CACHE" and not m.filepath.startswith("//")]
    if bad:
        sys.exit("import_blender: the point caches of %s could not be made relative to %s" % (", ".join(bad), path))


def main(argv):
    parser = argparse.ArgumentParser(
        prog="blender -b --python scripts/import_blender.py --",
        description="Imports a ccfr run (its blender/ point caches) into Blender.")
    parser.add_argument("run_dir", help="the run directory (with blender/manifest.json)")
    parser.add_argument("--z-up", action="store_true", help="rotate from ccfr's y-up to Blender's z-up")
    parser.add_argument("--save", metavar="OUT.blend", help="save the scene as this .blend file")
    parser.add_argument("--keep-scene", action="store_true",
                        help="keep the objects already in the scene (default: remove them)")
    args = parser.parse_args(argv)
    if not args.keep_scene:
        clear_scene()
    try:
        objects = import_run(args.run_dir, z_up=args.z_up)
    except (OSError, ValueError, KeyError) as e:
        print("import_blender: error: %s" % e, file=sys.stderr)
        return 1
    scene = bpy.context.scene
    print("import_blender: %d objects (%s), frames %d-%d at %g fps" %
          (len(objects), ", ".join(o.name for o in objects), scene.frame_start, scene.frame_end,
           scene.render.fps / scene.render.fps_base))
    if args.save:
        save_blend(args.save, objects)
        print("import_blender: saved %s" % os.path.abspath(args.save))
    return 0


if __name__ == "__main__":
    code = main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
    if code:
        sys.exit(code)  # Blender exits with it; without, it would carry on (and exit 0)
