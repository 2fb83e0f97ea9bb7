"""Run by tests/apps/test_interop.cpp inside the real Blender:

    blender -b --factory-startup --python check_blender.py -- RUN_DIR MODE FRAME...

MODE pc2: imports RUN_DIR with scripts/import_blender.py (Mesh Cache modifier); MODE usda: imports
RUN_DIR/usd/scene.usda with bpy.ops.wm.usd_import; MODE blend: checks the .blend Blender was started
with (`blender -b OUT.blend --python check_blender.py -- RUN_DIR blend ...`, a file saved by
import_blender.py --save) as it is. For each FRAME, evaluates every object at that
Blender frame and compares its vertex positions (object-local) with RUN_DIR/frames/frame_FRAME.obj.
Prints one line `RESULT {json}`: every object's name and type, the scene's frame range and fps, and
per frame the largest error and the vertices compared.
"""
import json
import os
import sys

import bpy

args = sys.argv[sys.argv.index("--") + 1:]
run_dir, mode, frames = args[0], args[1], [int(f) for f in args[2:]]
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
import import_blender  # noqa: E402

if mode != "blend":
    bpy.ops.wm.read_factory_settings(use_empty=True)
if mode == "blend":
    objects = [o for o in bpy.context.scene.objects if o.type == "MESH"]
elif mode == "pc2":
    objects = import_blender.import_run(run_dir)
else:
    bpy.ops.wm.usd_import(filepath=os.path.join(run_dir, "usd", "scene.usda"))
    objects = [o for o in bpy.context.scene.objects if o.type in ("MESH", "CURVES", "CURVE", "POINTCLOUD")]

scene = bpy.context.scene
result = {"mode": mode, "objects": len(objects), "frames": [],
          "all_objects": sorted([o.name, o.type] for o in bpy.data.objects),
          "frame_start": scene.frame_start, "frame_end": scene.frame_end,
          "fps": scene.render.fps / scene.render.fps_base}
for frame in frames:
    verts, blocks = import_blender.read_obj(os.path.join(run_dir, "frames", "frame_%05d.obj" % frame))
    bpy.context.scene.frame_set(frame)
    dg = bpy.context.evaluated_depsgraph_get()
    # Object ranges of the OBJ frame, by name, in its vertex order.
    ranges, start = {}, 0
    with open(os.path.join(run_dir, "frames", "frame_%05d.obj" % frame)) as f:
        name, count = None, 0
        for line in f:
            if line.startswith("o "):
                if name is not None:
                    ranges[name] = (start, start + count)
                    start += count
                name, count = line[2:].rstrip("\n"), 0
            elif line.startswith("v "):
                count += 1
        ranges[name] = (start, start + count)
    worst, compared, missing = 0.0, 0, []
    for obj in objects:
        key = obj.get("ccfr:name", None) or obj.data.get("ccfr:name", None) if hasattr(obj.data, "get") else None
        key = key or obj.name
        if key not in ranges:
            key = next((n for n in ranges if n.replace(" ", "_") == obj.name or n == obj.data.name), None)
        if key is None:
            missing.append(obj.name)
            continue
        b, e = ranges[key]
        ev = obj.evaluated_get(dg).data
        if len(ev.vertices) != e - b:
            missing.append("%s: %d vertices, frame has %d" % (obj.name, len(ev.vertices), e - b))
            continue
        for k, vert in enumerate(ev.vertices):
            ref = verts[b + k]
            worst = max(worst, max(abs(vert.co[i] - ref[i]) for i in range(3)))
            compared += 1
    result["frames"].append({"frame": frame, "max_error": worst, "compared": compared, "missing": missing})
print("RESULT " + json.dumps(result))
sys.stdout.flush()
