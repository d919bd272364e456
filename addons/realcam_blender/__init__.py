"""realcam in Blender: the scene camera's lens, aperture and shutter on the rendered passes.

After a render (Combined, Depth and Vector passes of the view layer; Cycles' depth of field and
motion blur off, so the passes are the pinhole's), or on an open multilayer EXR with those
passes, the operator `realcam.apply` runs the realcam command line on them with the scene
camera's own settings and loads the result as a new image. The panel (Properties > Output >
realcam) holds the lens file, the film and the source; the add-on's preferences the binary.

`realcam.apply_animation` does a shot: for each frame of the scene's range (frame_start ..
frame_end by frame_step) it sets the frame, renders (bpy.ops.render.render: blocking, so it works
alike headless and in the UI, and the Render Result, which holds one frame, is saved right after
each) and saves the passes as passes_NNNN.exr; it evaluates the camera at every frame first,
passes the settings that hold still as flags and writes those that change to a camera file, one
key per frame with constant interpolation (the very values Blender evaluated), then runs one
`realcam render --frames` over the range. The output is the panel's Output, where a run of #
is the frame number (a folder: realcam_####.exr in it; a name without #: _#### before its
extension), loaded as an image sequence; without one, a temporary folder, from which the scene's
current frame's result (else the last's) is loaded and packed.

Every temporary folder (the passes, the camera file, an output with no place of its own) is a
tempfile.TemporaryDirectory: removed when the operator ends, whether it succeeds or fails.

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
        name="Output",
        description=(
            "Where the result is written (the animation: a run of # is the frame number, e.g. //realcam/shot_####.exr; "
            "a folder gets realcam_####.exr); empty: a temporary folder, removed once the result is loaded and packed"
        ),
        subtype="FILE_PATH",
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


def camera_values(scene, settings):
    """The scene camera's settings at the scene's current frame, as (flag, camera-file setting,
    value); the setting is None for what realcam takes once per shot (sensor, fit, unit, fps,
    shutter position)."""
    camera_object = scene.camera
    if camera_object is None or camera_object.type != "CAMERA":
        raise ValueError("the scene has no camera")
    cam = camera_object.data
    if cam.type != "PERSP":
        raise ValueError(f"camera {camera_object.name!r} is {cam.type}: realcam models perspective lenses")
    unit_m = scene.unit_settings.scale_length if scene.unit_settings.system != "NONE" else 1.0
    return [
        ("--focal-length", "focal_length_mm", cam.lens),
        ("--sensor", None, f"{num(cam.sensor_width)}x{num(cam.sensor_height)}"),
        ("--sensor-fit", None, cam.sensor_fit.lower()),
        ("--fstop", "f_number", cam.dof.aperture_fstop),
        ("--focus", "focus_distance_m", focus_distance_m(scene, camera_object) * unit_m),
        # Blender: fewer than 3 blades is a round aperture; realcam: 0.
        ("--blades", "blades", cam.dof.aperture_blades if cam.dof.aperture_blades >= 3 else 0),
        ("--blade-rotation", "blade_rotation_deg", math.degrees(cam.dof.aperture_rotation)),
        ("--depth-unit", None, unit_m),
        ("--fps", None, scene.render.fps / scene.render.fps_base),
        ("--shutter-angle", "shutter_angle_deg", 360.0 * scene.render.motion_blur_shutter),
        ("--shutter-position", None, shutter_position(scene)),
        ("--iso", "iso", settings.iso),
    ]


def flag(name, value):
    return f"{name}={num(value) if isinstance(value, float) else value}"


def panel_flags(settings):
    """realcam render's flags for the panel's settings (one per run)."""
    flags = []
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


def camera_flags(scene, settings):
    """realcam render's flags for the scene camera at the current frame and the panel's settings."""
    return [flag(name, value) for name, _, value in camera_values(scene, settings)] + panel_flags(settings)


def shot_camera(scene, settings, frames):
    """The scene camera over `frames` (each evaluated with scene.frame_set): the flags of the
    settings that hold still, and {camera-file setting: [(frame, value), ...]} for those that
    change. A setting realcam takes once per shot that changes is an error."""
    evaluated = []
    for frame in frames:
        scene.frame_set(frame)
        evaluated.append(camera_values(scene, settings))
    flags, tracks = [], {}
    for i, (name, setting, first) in enumerate(evaluated[0]):
        values = [(frame, row[i][2]) for frame, row in zip(frames, evaluated)]
        if all(value == first for _, value in values):
            flags.append(flag(name, first))
        elif setting is None:
            changes = next(f"{first} at frame {frames[0]}, {v} at frame {f}" for f, v in values if v != first)
            raise ValueError(f"{name[2:]} changes over the frames ({changes}): realcam takes one per shot")
        else:
            tracks[setting] = values
    return flags + panel_flags(settings), tracks


def toml_number(value):
    """A TOML number: an int as it is, a float as Python's repr (the exact double of Blender's
    single-precision value: realcam reads back the very value Blender evaluated)."""
    return str(value) if isinstance(value, int) else repr(float(value))


def camera_file_text(tracks):
    """A realcam camera file (docs/shots.md): one key per frame, constant interpolation."""
    lines = ["# The scene camera as Blender evaluated it at each frame (realcam Blender add-on)."]
    for setting, keys in tracks.items():
        lines.append(f"[{setting}]")
        lines.append('interpolation = "constant"')
        lines.append("keys = [" + ", ".join(f"[{frame}, {toml_number(v)}]" for frame, v in keys) + "]")
        lines.append("")
    return "\n".join(lines)


def frame_path(pattern, frame):
    """`pattern`'s path for `frame`: its run of # as the frame number, zero-padded to the run's
    width counting the sign (printf's %0Nd, as realcam and Blender write it)."""
    text = str(pattern)
    start = text.index("#")
    end = start
    while end < len(text) and text[end] == "#":
        end += 1
    return Path(f"{text[:start]}{frame:0{end - start}d}{text[end:]}")


def output_pattern(settings, folder):
    """Where the animation's frames go: the panel's Output with a run of # for the frame number
    (a folder: realcam_####.exr in it; a name without #: _#### before its extension), else a
    temporary folder. Returns the pattern and whether the user asked for it."""
    if not settings.output:
        return folder / "realcam_####.exr", False
    path = bpy.path.abspath(settings.output)
    if path.endswith(("/", os.sep)) or os.path.isdir(path):
        return Path(path) / "realcam_####.exr", True
    head, name = os.path.split(path)
    if "#" not in name:
        stem, ext = os.path.splitext(name)
        name = f"{stem}_####{ext or '.exr'}"
    return Path(head) / name, True


def run_realcam(command):
    """Runs realcam; its error's last line as a ValueError (its whole stderr on the console)."""
    print(" ".join(command))
    run = subprocess.run(command, capture_output=True, text=True)
    print(run.stderr)
    if run.returncode != 0:
        lines = run.stderr.strip().splitlines()
        raise ValueError(lines[-1] if lines else f"realcam exited with {run.returncode}")


def load_result(path, name, pack):
    """The result as a new image; packed (read into the .blend) when its file is about to go."""
    image = bpy.data.images.load(str(path), check_existing=False)
    image.name = name
    if pack:
        image.pack()
    return image


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


def binary_or_report(operator, context):
    binary = find_binary(context)
    if not binary or not os.path.isfile(binary):
        operator.report({"ERROR"}, "realcam binary not found: set it in the add-on's preferences, or put realcam on PATH")
        return None
    return binary


class REALCAM_OT_apply(bpy.types.Operator):
    """Run realcam on the view layer's Combined, Depth and Vector passes with the scene camera's settings"""

    bl_idname = "realcam.apply"
    bl_label = "Apply realcam camera"

    def execute(self, context):
        scene = context.scene
        settings = scene.realcam
        binary = binary_or_report(self, context)
        if binary is None:
            return {"CANCELLED"}
        # The passes (and the output, unless the panel names one) live in a folder that goes
        # when the operator ends, however it ends; an output kept there is packed first.
        with tempfile.TemporaryDirectory(prefix="realcam-") as temporary:
            folder = Path(temporary)
            try:
                flags = camera_flags(scene, settings)
                if settings.source:
                    source = Path(bpy.path.abspath(settings.source))
                else:
                    source = folder / "passes.exr"
                    save_render_result(scene, source)
                if scene.camera.data.dof.use_dof and not settings.source:
                    self.report({"WARNING"}, "the render has the camera's depth of field already: turn it off for pinhole passes")
                if not settings.output:
                    output = folder / "realcam.exr"
                elif "#" in os.path.basename(settings.output):  # the animation's pattern: this frame's file
                    output = frame_path(output_pattern(settings, folder)[0], scene.frame_current)
                else:
                    output = Path(bpy.path.abspath(settings.output))
                command = [binary, "render", "--color", str(source), "--layer", context.view_layer.name, *flags]
                # The frame number seeds the grain: the frame gets the grain it gets in the shot.
                command.append(f"--frame={scene.frame_current}")
                run_realcam(command + ["--float", "--explain", "-o", str(output)])
                image = load_result(output, f"realcam {scene.camera.name}", pack=not settings.output)
            except (ValueError, RuntimeError, OSError) as e:
                self.report({"ERROR"}, f"realcam: {e}")
                return {"CANCELLED"}
        settings.last_image = image.name
        self.report({"INFO"}, f"realcam: {image.name} from {output if settings.output else 'a temporary file (packed)'}")
        return {"FINISHED"}


class REALCAM_OT_apply_animation(bpy.types.Operator):
    """Render every frame of the scene's frame range and run realcam over them as one shot, with the scene camera's animation"""

    bl_idname = "realcam.apply_animation"
    bl_label = "Apply realcam to the animation"

    def execute(self, context):
        scene = context.scene
        settings = scene.realcam
        binary = binary_or_report(self, context)
        if binary is None:
            return {"CANCELLED"}
        frames = list(range(scene.frame_start, scene.frame_end + 1, scene.frame_step))
        if not frames:
            self.report({"ERROR"}, f"realcam: the frame range {scene.frame_start}-{scene.frame_end} is empty")
            return {"CANCELLED"}
        current = scene.frame_current
        shown = current if current in frames else frames[-1]
        with tempfile.TemporaryDirectory(prefix="realcam-") as temporary:
            folder = Path(temporary)
            try:
                try:
                    flags, tracks = shot_camera(scene, settings, frames)
                    if scene.camera.data.dof.use_dof:
                        self.report({"WARNING"}, "the camera's depth of field is on in the render: turn it off for pinhole passes")
                    passes = folder / "passes_####.exr"
                    progress = context.window_manager
                    progress.progress_begin(0, len(frames))
                    for i, frame in enumerate(frames):
                        scene.frame_set(frame)
                        if bpy.ops.render.render() != {"FINISHED"}:
                            raise ValueError(f"Blender's render of frame {frame} did not finish")
                        save_render_result(scene, frame_path(passes, frame))
                        progress.progress_update(i + 1)
                finally:
                    context.window_manager.progress_end()
                    scene.frame_set(current)
                output, kept = output_pattern(settings, folder)
                output.parent.mkdir(parents=True, exist_ok=True)
                command = [binary, "render", f"--frames={frames[0]}-{frames[-1]}"]
                if scene.frame_step > 1:
                    command[-1] += f"x{scene.frame_step}"
                command += ["--color", str(passes), "--layer", context.view_layer.name, *flags]
                if tracks:
                    camera_file = folder / "camera.toml"
                    camera_file.write_text(camera_file_text(tracks))
                    command.append(f"--camera-file={camera_file}")
                run_realcam(command + ["--float", "--explain", "--fail-fast", "-o", str(output)])
                missing = [frame for frame in frames if not frame_path(output, frame).is_file()]
                if missing:
                    raise ValueError(f"realcam wrote no output for frames {missing}")
                name = f"realcam {scene.camera.name}"
                if kept:
                    # The frames stay where the user asked: an image sequence from the first.
                    image = load_result(frame_path(output, frames[0]), name, pack=False)
                    image.source = "SEQUENCE"
                else:
                    # Only the current frame's result (else the last) outlives the folder, packed.
                    image = load_result(frame_path(output, shown), name, pack=True)
            except (ValueError, RuntimeError, OSError) as e:
                self.report({"ERROR"}, f"realcam: {e}")
                return {"CANCELLED"}
        settings.last_image = image.name
        animated = ", ".join(tracks) or "nothing"
        where = output if kept else f"frame {shown}, packed (set Output to keep every frame)"
        self.report({"INFO"}, f"realcam: {len(frames)} frames ({animated} animated); {image.name}: {where}")
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
        layout.operator(REALCAM_OT_apply_animation.bl_idname)


CLASSES = (RealcamPreferences, RealcamSettings, REALCAM_OT_apply, REALCAM_OT_apply_animation, REALCAM_PT_panel)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.realcam = bpy.props.PointerProperty(type=RealcamSettings)


def unregister():
    del bpy.types.Scene.realcam
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)

