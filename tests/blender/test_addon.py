"""The Blender add-on in Blender: renders a tiny Cycles scene (a small emissive sphere behind the
focus plane on black; Combined, Depth and Vector passes; the camera's depth of field and the
render's motion blur off, so the passes are the pinhole's), runs the add-on's operator on the
render result, and checks that the defocused sphere's disc in the loaded image has the diameter
of eq 5.3 for the scene camera; then, the sphere in focus and moving, that its streak has the
length and side the Vector pass and the shutter give.

    blender -b --factory-startup --python-exit-code 1 -P tests/blender/test_addon.py

Run by scripts/test-blender.sh; the realcam binary is REALCAM_BIN (else realcam on PATH, else the
repository's target/release/realcam). Any failed check raises: Blender exits with 1.
"""

import math
import os
import sys
from pathlib import Path

import bpy

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "addons"))
if os.environ.get("REALCAM_BIN"):
    os.environ["PATH"] = str(Path(os.environ["REALCAM_BIN"]).parent) + os.pathsep + os.environ["PATH"]
import realcam_blender  # noqa: E402

W, H = 160, 90
FOCAL_MM, SENSOR_MM, F_NUMBER = 50.0, 36.0, 1.4
FOCUS_M, SPHERE_M, SPHERE_RADIUS_M = 0.6, 3.0, 0.015
SPHERE_X_M, SPHERE_Y_M = 0.25, 0.1
PITCH_MM = SENSOR_MM / W  # AUTO fit, landscape: the sensor width spans the image width


def build_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 16
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = W, H, 100
    scene.render.use_motion_blur = False
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world
    layer = scene.view_layers[0]
    layer.use_pass_combined = layer.use_pass_z = layer.use_pass_vector = True

    cam = bpy.data.cameras.new("Lens")
    cam.lens, cam.sensor_width, cam.sensor_fit = FOCAL_MM, SENSOR_MM, "AUTO"
    cam.dof.use_dof = False  # pinhole passes; the add-on still reads the settings below
    cam.dof.aperture_fstop = F_NUMBER
    cam.dof.aperture_blades = 0
    cam.dof.focus_distance = 10.0  # not used: the focus object decides
    camera = bpy.data.objects.new("Camera", cam)  # at the origin, looking down -Z
    scene.collection.objects.link(camera)
    scene.camera = camera
    focus = bpy.data.objects.new("Focus", None)
    focus.location = (0.05, -0.02, -FOCUS_M)
    scene.collection.objects.link(focus)
    cam.dof.focus_object = focus

    bpy.ops.mesh.primitive_uv_sphere_add(radius=SPHERE_RADIUS_M, location=(SPHERE_X_M, SPHERE_Y_M, -SPHERE_M))
    sphere = bpy.context.active_object
    material = bpy.data.materials.new("light")
    material.use_nodes = True
    nodes = material.node_tree.nodes
    nodes.clear()
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 50.0
    output = nodes.new("ShaderNodeOutputMaterial")
    material.node_tree.links.new(emission.outputs["Emission"], output.inputs["Surface"])
    sphere.data.materials.append(material)
    return scene, focus, sphere


def px(metres):
    """A length across the view at the sphere's depth, in pixels (the pinhole's scale)."""
    return metres / SPHERE_M * FOCAL_MM / PITCH_MM


def apply_and_measure(scene):
    result = bpy.ops.realcam.apply()
    assert result == {"FINISHED"}, result
    image = bpy.data.images[scene.realcam.last_image]
    assert tuple(image.size) == (W, H), tuple(image.size)
    return moments(image.pixels[:])


def moments(pixels):
    """Energy, centroid and per-axis variance (px^2) of the image's RGB sum, x right, y up."""
    total = sx = sy = 0.0
    values = []
    for i in range(W * H):
        v = pixels[4 * i] + pixels[4 * i + 1] + pixels[4 * i + 2]
        if v > 0.0:
            x, y = i % W + 0.5, i // W + 0.5
            values.append((x, y, v))
            total += v
            sx += v * x
            sy += v * y
    cx, cy = sx / total, sy / total
    var_x = sum(v * (x - cx) ** 2 for x, y, v in values) / total
    var_y = sum(v * (y - cy) ** 2 for x, y, v in values) / total
    return total, (cx, cy), var_x, var_y


def main():
    realcam_blender.register()
    scene, focus, sphere = build_scene()
    bpy.ops.render.render()
    settings = scene.realcam
    settings.film = "linear"  # values proportional to the light
    settings.exposure = False
    settings.flare = False  # the starburst and halo would widen the disc
    settings.max_coc = "64px"  # wider than this f/1.4 disc (realcam clamps nothing by default)
    total, centre, var_x, var_y = apply_and_measure(scene)

    # Eq 5.3 as Cycles' thin lens at the pinhole draws it (realcam --lens ideal: the renderer's
    # CoC model, docs/design.md, "Which thin lens"): C = A f |u - S| / (u S), A = f / N, over the pixel
    # pitch; S: the focus object's depth, u: the sphere's.
    coc_mm = (FOCAL_MM / F_NUMBER) * FOCAL_MM * abs(1.0 / (FOCUS_M * 1000) - 1.0 / (SPHERE_M * 1000))
    expected_px = coc_mm / PITCH_MM
    # A uniform disc of diameter D has variance D^2 / 16 per axis; the pinhole image of the
    # sphere (a disc of radius R px, in 1 px pixels) adds R^2 / 4 + 1 / 12.
    pinhole_var = px(SPHERE_RADIUS_M) ** 2 / 4 + 1 / 12
    measured_px = 4 * math.sqrt((var_x + var_y) / 2 - pinhole_var)
    # Where the sphere is: its pinhole position (the disc is centred on it); y up, as Blender's pixels.
    x_px, y_px = W / 2 + px(SPHERE_X_M), H / 2 + px(SPHERE_Y_M)
    print(
        f"realcam add-on: disc diameter {measured_px:.2f} px, eq 5.3 {expected_px:.2f} px; "
        f"centre ({centre[0]:.2f}, {centre[1]:.2f}) px, pinhole ({x_px:.2f}, {y_px:.2f}); energy {total:.1f}"
    )
    assert 10.0 < expected_px < 40.0, expected_px  # a disc worth measuring, within the clamp
    assert abs(measured_px - expected_px) < 1.0, (measured_px, expected_px)
    assert math.hypot(centre[0] - x_px, centre[1] - y_px) < 0.5, (centre, (x_px, y_px))
    # Round: the aperture is circular (blades 0), so both axes agree.
    assert abs(var_x - var_y) < 0.05 * (var_x + var_y), (var_x, var_y)

    # The Vector pass: the sphere in focus at f/16 (every CoC under 1 px: no depth of field),
    # moving right by MOVE_PX per frame (linear keys at frames 0, 1, 2; frame 1 rendered). The
    # shutter open half a frame from the frame time (START) draws a streak L = MOVE_PX / 2 from
    # the pinhole position toward the next frame's: the centroid moves right by L / 2 and the x
    # variance grows by L^2 / 12. A wrong sign, axis or unit of the Vector pass (y up, X,Y vs
    # Z,W, px per shutter) moves the centroid left or up, or doubles or halves L. Tolerances:
    # where the sphere was in the pinhole image the background is hidden, and realcam fills it
    # from the sphere's own texels (docs/measurements.md, motion blur against Cycles), which adds light at the
    # streak's start: measured L 6.88 px, shift 2.46 px.
    move_px = 12.0
    focus.location = (0.0, 0.0, -SPHERE_M)
    scene.camera.data.dof.aperture_fstop = 16.0
    step_m = move_px * SPHERE_M * PITCH_MM / FOCAL_MM
    for frame in (0, 1, 2):
        sphere.location.x = SPHERE_X_M + (frame - 1) * step_m
        sphere.keyframe_insert("location", index=0, frame=frame)
    for key in sphere.animation_data.action.fcurves[0].keyframe_points:
        key.interpolation = "LINEAR"
    scene.frame_set(1)
    scene.render.motion_blur_shutter = 0.5
    scene.cycles.motion_blur_position = "START"
    bpy.ops.render.render()
    _, centre, var_x, var_y = apply_and_measure(scene)
    streak_px = math.sqrt(12 * max(var_x - var_y, 0.0))
    print(
        f"realcam add-on: streak {streak_px:.2f} px (expected {move_px / 2:.2f}), centroid "
        f"({centre[0]:.2f}, {centre[1]:.2f}) px, pinhole ({x_px:.2f}, {y_px:.2f})"
    )
    assert abs(streak_px - move_px / 2) < 1.0, streak_px
    assert abs(centre[0] - (x_px + move_px / 4)) < 0.75, (centre, x_px)
    assert abs(centre[1] - y_px) < 0.3, (centre, y_px)

    # A camera the add-on cannot use is a clear error, not a crash.
    scene.camera.data.type = "ORTHO"
    try:
        bpy.ops.realcam.apply()
        raise AssertionError("an orthographic camera was accepted")
    except RuntimeError as e:
        assert "is ORTHO: realcam models perspective lenses" in str(e), str(e)
    print("realcam add-on: ok")


main()
