"""Headless screenshot of a ccfr run in Blender (docs/images/interop_blender.png):

    blender -b RUN.blend --python scripts/blender_screenshot.py -- OUT.png FRAME
    blender -b --factory-startup --python scripts/blender_screenshot.py -- RUN_DIR OUT.png FRAME

Renders the meshes of RUN.blend (saved by `import_blender.py RUN_DIR --z-up --save RUN.blend`), or
imports RUN_DIR with import_blender.py (PC2 caches, z-up); aims a camera at the origin and renders
FRAME with the Workbench engine (no GPU needed).
"""
import bpy, sys, os, math
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import import_blender
args = sys.argv[sys.argv.index("--") + 1:]
if bpy.data.filepath:  # started with a .blend: its meshes
    objs = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    args = [None] + args
else:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    objs = import_blender.import_run(args[0], z_up=True)
scene = bpy.context.scene
scene.frame_set(int(args[2]))
cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
scene.collection.objects.link(cam); scene.camera = cam
cam.location = (1.2, -1.4, 1.1)
target = bpy.data.objects.new("target", None); scene.collection.objects.link(target); target.location = (0, 0, 0.15)
c = cam.constraints.new("TRACK_TO"); c.target = target; c.track_axis = "TRACK_NEGATIVE_Z"; c.up_axis = "UP_Y"
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN")); sun.rotation_euler = (0.6, 0.2, 0.4)
scene.collection.objects.link(sun)
world = bpy.data.worlds.new("w"); scene.world = world; world.color = (0.8, 0.8, 0.85)
for o in objs:
    mat = bpy.data.materials.new(o.name); o.data.materials.append(mat)
    mat.diffuse_color = (0.8, 0.3, 0.2, 1) if o.name == "cloth" else (0.3, 0.5, 0.8, 1)
scene.render.engine = "BLENDER_WORKBENCH"
scene.display.shading.color_type = "MATERIAL"
scene.render.resolution_x, scene.render.resolution_y = 640, 480
scene.render.filepath = args[1]
bpy.ops.render.render(write_still=True)
