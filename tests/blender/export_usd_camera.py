"""A rack focus and an iris pull keyed in Blender, exported by Blender's own USD exporter.

    python export_usd_camera.py OUT.usda

Run with Blender as a Python module (`bpy`, 4.2 LTS from PyPI, built with USD: Debian's Blender
3.4 is built without it), by tests/shot_camera.rs. The scene camera, 50 mm on a 36 mm wide
sensor, keyed at frame 1 (focus 1 m, f/2) and frame 3 (focus 3 m, f/8), Blender's default
Bezier keys between; the exporter writes one time sample per frame of the scene's range 1-3.
"""

import sys

import bpy

out = sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else sys.argv[1]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, 3
camera_data = bpy.data.cameras.new("Camera")
camera = bpy.data.objects.new("Camera", camera_data)
scene.collection.objects.link(camera)
scene.camera = camera
camera_data.lens = 50.0
camera_data.sensor_width = 36.0
camera_data.dof.use_dof = True
for frame, focus_m, f_number in [(1, 1.0, 2.0), (3, 3.0, 8.0)]:
    camera_data.dof.focus_distance = focus_m
    camera_data.dof.aperture_fstop = f_number
    camera_data.dof.keyframe_insert("focus_distance", frame=frame)
    camera_data.dof.keyframe_insert("aperture_fstop", frame=frame)
result = bpy.ops.wm.usd_export(filepath=out, export_animation=True, selected_objects_only=False)
if result != {"FINISHED"}:
    sys.exit(f"export_usd_camera.py: Blender's USD export returned {result}")
