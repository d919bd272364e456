"""realcam in Blender: the scene camera's lens, aperture and shutter on the rendered passes.

After a render (Combined, Depth and Vector passes of the view layer; Cycles' depth of field and
motion blur off, so the passes are the pinhole's), or on an open multilayer EXR with those
passes, the operator `realcam.apply` runs the realcam command line on them with the scene
camera's own settings and loads the result as a new image. The panel (Properties > Output >
realcam) holds the lens file, the film and the source; the add-on's preferences the binary.

What the camera gives (README.md, "Blender"):
- focal length, sensor width and height and the sensor fit (AUTO/HORIZONTAL/VERTICAL), as
  `--focal-length`, `--sensor WxH`, `--sensor-fit`;
- the f-stop, the focus distance or the focus object's distance along the view axis (planar, as
  the Depth pass), the blades and their rotation, as `--fstop`, `--focus`, `--blades`,
  `--blade-rotation`;
- the shutter (`motion_blur_shutter`, in frames), its position and the frame rate (fps /
  fps_base), as `--shutter-angle` (360 x shutter), `--shutter-position` and `--fps`;
- the scene's unit scale as `--depth-unit` (the Depth pass is in scene units).
The Vector pass is written by Blender as X,Y = p[f-1] - p[f], Z,W = p[f] - p[f+1] in pixels, y
up; realcam reads it in that convention (`--velocity-format blender`, chosen from the channel
names) and turns it into px per frame toward the next frame, y down.
"""

import math
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import bpy

bl_info = {
    "name": "realcam",
    "author": "realcam",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Output > realcam",
    "description": "A realistic camera (depth of field, motion blur, vignetting, film) on the render passes",
    "category": "Render",
}

FILMS = [
    ("linear", "Linear", "Scene-referred linear values (for compositing)"),
    ("filmic", "Filmic", "realcam's characteristic curve (display-referred)"),
    ("contrast", "Contrast", "A steeper curve with a harder shoulder"),
    ("soft", "Soft", "A flatter curve with a long toe and shoulder"),
]


# Blender's shutter position (when the shutter opens around the frame time) as realcam's.
SHUTTER_POSITIONS = {"START": "start", "CENTER": "centred", "END": "end"}


def shutter_position(scene):
    """Cycles' shutter position (Blender 3.x: scene.cycles); other engines centre the shutter."""
    cycles = getattr(scene, "cycles", None)
    return SHUTTER_POSITIONS.get(getattr(cycles, "motion_blur_position", "CENTER"), "centred")


def repository_binary():
    """The command line built in the repository this add-on lies in (target/release), if any."""
    built = Path(__file__).resolve().parents[2] / "target" / "release" / "realcam"
    return str(built) if built.is_file() else None


def find_binary(context):
    prefs = context.preferences.addons.get(__name__)
    chosen = prefs.preferences.binary if prefs else ""
    if chosen:
        return bpy.path.abspath(chosen)
    return shutil.which("realcam") or repository_binary()


class RealcamPreferences(bpy.types.AddonPreferences):
    bl_idname = __name__

    binary: bpy.props.StringProperty(
        name="realcam binary",
        description="The realcam command line; empty: realcam on PATH, else the repository's target/release/realcam",
        subtype="FILE_PATH",
        default="",
    )

    def draw(self, context):
        self.layout.prop(self, "binary")


class RealcamSettings(bpy.types.PropertyGroup):
    lens_file: bpy.props.StringProperty(
        name="Lens file",
        description="A realcam lens file (lenses/*.toml); empty: the ideal thin lens of the renderer (Cycles' own CoC)",
        subtype="FILE_PATH",
        default="",
    )
    film: bpy.props.EnumProperty(name="Film", items=FILMS, default="linear")
    film_file: bpy.props.StringProperty(
        name="Film file", description="A realcam film file (films/*.toml), instead of Film", subtype="FILE_PATH"
    )
    exposure: bpy.props.BoolProperty(
        name="Exposure",
        description="Scale by the exposure of ISO, shutter and f-number (off: the render's values are the sensor's)",
        default=False,
    )
    iso: bpy.props.FloatProperty(name="ISO", default=100.0, min=1.0)
    max_coc: bpy.props.StringProperty(
        name="Max CoC",
        description="Clamp on the CoC diameter: on the film (1.2mm) or in pixels (64px); empty: realcam's default, none",
        default="",
    )
    flare: bpy.props.BoolProperty(
        name="Lens flare",
        description="Ghosts, starburst and halo around lights (off: the renderer's camera, the ideal lens, draws none)",
        default=False,
    )
    source: bpy.props.StringProperty(
        name="Source EXR",
        description="A multilayer EXR with Combined, Depth and Vector passes; empty: the last render",
        subtype="FILE_PATH",
        default="",
    )
    output: bpy.props.StringProperty(
        name="Output", description="Where the result is written; empty: a temporary folder", subtype="FILE_PATH"
    )
    last_image: bpy.props.StringProperty(name="Last result", default="")


def focus_distance_m(scene, camera_object):
    """The focus distance in scene units: the focus object's along the camera's view axis
    (planar, as the Depth pass measures), else the camera's focus distance."""
    dof = camera_object.data.dof
    if dof.focus_object is not None:
        target = dof.focus_object.matrix_world.translation
        local = camera_object.matrix_world.inverted() @ target
        return max(-local.z, 1e-6)
    return dof.focus_distance


def num(value):
    """A Blender float (single precision) as the decimal it was typed as: 1.4, not 1.399999976."""
    return f"{value:.7g}"


def camera_flags(scene, settings):
    """realcam render's flags for the scene camera and the panel's settings."""
    camera_object = scene.camera
    if camera_object is None or camera_object.type != "CAMERA":
        raise ValueError("the scene has no camera")
    cam = camera_object.data
    if cam.type != "PERSP":
        raise ValueError(f"camera {camera_object.name!r} is {cam.type}: realcam models perspective lenses")
    unit_m = scene.unit_settings.scale_length if scene.unit_settings.system != "NONE" else 1.0
    flags = [
        f"--focal-length={num(cam.lens)}",
        f"--sensor={num(cam.sensor_width)}x{num(cam.sensor_height)}",
        f"--sensor-fit={cam.sensor_fit.lower()}",
        f"--fstop={num(cam.dof.aperture_fstop)}",
        f"--focus={num(focus_distance_m(scene, camera_object) * unit_m)}",
        # Blender: fewer than 3 blades is a round aperture; realcam: 0.
        f"--blades={cam.dof.aperture_blades if cam.dof.aperture_blades >= 3 else 0}",
        f"--blade-rotation={num(math.degrees(cam.dof.aperture_rotation))}",
        f"--depth-unit={num(unit_m)}",
        f"--fps={num(scene.render.fps / scene.render.fps_base)}",
        f"--shutter-angle={num(360.0 * scene.render.motion_blur_shutter)}",
        f"--shutter-position={shutter_position(scene)}",
        f"--iso={num(settings.iso)}",
    ]
    if settings.lens_file:
        flags.append(f"--lens={bpy.path.abspath(settings.lens_file)}")
    else:
        flags.append("--lens=ideal")
    if settings.film_file:
        flags.append(f"--film-file={bpy.path.abspath(settings.film_file)}")
    else:
        flags.append(f"--film={settings.film}")
    if settings.max_coc:
        flags.append(f"--max-coc={settings.max_coc}")
    if not settings.exposure:
        flags.append("--no-exposure")
    flags.append("--flare" if settings.flare else "--no-flare")
    return flags


def save_render_result(scene, path):
    """The last render's passes as a 32-bit multilayer EXR (every pass of every view layer)."""
    result = bpy.data.images.get("Render Result")
    if result is None:
        raise ValueError("no render result: render first (F12), or set a source EXR in the realcam panel")
    settings = scene.render.image_settings
    kept = (settings.file_format, settings.color_depth, settings.exr_codec)
    try:
        settings.file_format = "OPEN_EXR_MULTILAYER"
        settings.color_depth = "32"
        settings.exr_codec = "ZIP"
        result.save_render(filepath=str(path), scene=scene)
    finally:
        settings.file_format, settings.color_depth, settings.exr_codec = kept


class REALCAM_OT_apply(bpy.types.Operator):
    """Run realcam on the view layer's Combined, Depth and Vector passes with the scene camera's settings"""

    bl_idname = "realcam.apply"
    bl_label = "Apply realcam camera"

    def execute(self, context):
        scene = context.scene
        settings = scene.realcam
        binary = find_binary(context)
        if not binary or not os.path.isfile(binary):
            self.report({"ERROR"}, "realcam binary not found: set it in the add-on's preferences, or put realcam on PATH")
            return {"CANCELLED"}
        folder = Path(tempfile.mkdtemp(prefix="realcam-"))
        try:
            flags = camera_flags(scene, settings)
            if settings.source:
                source = Path(bpy.path.abspath(settings.source))
            else:
                source = folder / "passes.exr"
                save_render_result(scene, source)
        except ValueError as e:
            self.report({"ERROR"}, f"realcam: {e}")
            return {"CANCELLED"}
        if scene.camera.data.dof.use_dof and not settings.source:
            self.report({"WARNING"}, "the render has the camera's depth of field already: turn it off for pinhole passes")
        output = Path(bpy.path.abspath(settings.output)) if settings.output else folder / "realcam.exr"
        command = [binary, "render", "--color", str(source), "--layer", context.view_layer.name, *flags]
        command += ["--float", "--explain", "-o", str(output)]
        run = subprocess.run(command, capture_output=True, text=True)
        if run.returncode != 0:
            lines = run.stderr.strip().splitlines()
            message = lines[-1] if lines else f"realcam exited with {run.returncode}"
            self.report({"ERROR"}, message)
            print(run.stderr)
            return {"CANCELLED"}
        print(run.stderr)
        image = bpy.data.images.load(str(output), check_existing=False)
        image.name = f"realcam {scene.camera.name}"
        settings.last_image = image.name
        self.report({"INFO"}, f"realcam: {image.name} from {output}")
        return {"FINISHED"}


class REALCAM_PT_panel(bpy.types.Panel):
    bl_label = "realcam"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "output"

    def draw(self, context):
        settings = context.scene.realcam
        layout = self.layout
        layout.prop(settings, "lens_file")
        layout.prop(settings, "film")
        layout.prop(settings, "film_file")
        row = layout.row()
        row.prop(settings, "exposure")
        row.prop(settings, "iso")
        layout.prop(settings, "flare")
        layout.prop(settings, "max_coc")
        layout.prop(settings, "source")
        layout.prop(settings, "output")
        layout.operator(REALCAM_OT_apply.bl_idname)


CLASSES = (RealcamPreferences, RealcamSettings, REALCAM_OT_apply, REALCAM_PT_panel)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.realcam = bpy.props.PointerProperty(type=RealcamSettings)


def unregister():
    del bpy.types.Scene.realcam
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)

