"""Imports a ccfr run into Blender as animated meshes, without add-ons.

    blender --python scripts/import_blender.py -- RUN_DIR [--z-up]

RUN_DIR must hold blender/ (written by `output.formats: [pc2]` or `ccfr export RUN_DIR --format pc2`):
first_frame.obj, one .pc2 point cache per object and manifest.json. Each object becomes a mesh
built from the first frame in ccfr's vertex order (faces, strand edges, loose particle vertices),
with a Mesh Cache modifier (PC2) that plays the run: Blender frame F shows ccfr frame F. The
scene's fps and frame range follow the run. --z-up rotates the objects (not their vertices) from
ccfr's y-up to Blender's z-up.
"""
import json
import math
import os
import sys

import bpy


def read_obj(path):
    """Vertices, faces, lines and points of a ccfr frame (1-based global indices)."""
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


def import_run(run_dir, z_up=False):
    bdir = os.path.join(run_dir, "blender")
    with open(os.path.join(bdir, "manifest.json")) as f:
        manifest = json.load(f)
    verts, _ = read_obj(os.path.join(bdir, manifest["first_frame"]))
    _, blocks = read_obj(os.path.join(bdir, manifest["first_frame"]))
    every = max(1, int(manifest["every"]))
    scene = bpy.context.scene
    fps = float(manifest["fps"])
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
        scene.collection.objects.link(obj)
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
        objects.append(obj)
    scene.frame_end = last
    return objects


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if not args:
        sys.exit("usage: blender --python import_blender.py -- RUN_DIR [--z-up]")
    import_run(args[0], z_up="--z-up" in args)
