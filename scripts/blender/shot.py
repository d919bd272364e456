"""A shot through Blender's compositor: a multilayer EXR sequence (Combined, Depth, Vector) through
the Defocus node, then the Vector Blur node, rendered as an animation into EXRs: the peer of
`realcam render --frames` with depth of field and motion blur (issue 31, "Speed on a shot").

Run by scripts/compare-blender-shot.sh as
  blender -b --factory-startup -noaudio --python-exit-code 1 --python shot.py -- \
      --passes 'DIR/passes_####.exr' --frames 12 --output 'OUT/blender_####.exr' --fstop 2 --focus 2
With --no-defocus, Vector Blur alone. Checked with Blender 3.4.1 (Debian 12). Nothing is rendered: the tree has no Render Layers node,
so Blender only composites each frame and writes it. The Defocus node's f-stop and camera are
matched to the thin lens as scripts/blender/defocus.py explains; the Vector Blur takes the
shutter as its factor (0.5: a 180-degree shutter) with 32 samples.
"""
import argparse
import math
import sys

import bpy

BOKEH = {0: "CIRCLE", 3: "TRIANGLE", 4: "SQUARE", 5: "PENTAGON", 6: "HEXAGON", 7: "HEPTAGON", 8: "OCTAGON"}
F_STOP_MAX = 128.0


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="shot.py", description=__doc__.split("\n")[0])
    p.add_argument("--passes", required=True, help="the frames' multilayer EXRs, #### for the frame number")
    p.add_argument("--frames", type=int, required=True, help="frames 1..N")
    p.add_argument("--output", required=True, help="output EXRs, #### for the frame number")
    p.add_argument("--fstop", type=float, required=True)
    p.add_argument("--focus", type=float, required=True, help="focus distance in metres (planar)")
    p.add_argument("--focal-length", type=float, default=50.0)
    p.add_argument("--sensor-width", type=float, default=36.0)
    p.add_argument("--blades", type=int, default=6)
    p.add_argument("--shutter", type=float, default=0.5, help="shutter in frames (the Vector Blur's factor)")
    p.add_argument("--no-defocus", action="store_true",
                   help="Vector Blur alone, no Defocus node (the peer of realcam's motion blur alone)")
    p.add_argument("--blur-max", type=float, default=32.0,
                   help="the Defocus node's largest blur radius in px (32 covers scene A at f/2: CoC up to 35 px across)")
    return p.parse_args(argv)


def exr_size(path):
    """Width and height of an EXR's data window, from its header: attributes are name\\0
    type\\0 size (int32 LE) value, until an empty name; dataWindow is a box2i (four int32)."""
    data = open(path, "rb").read(1 << 16)
    at = 8
    while data[at] != 0:
        name_end = data.index(b"\0", at)
        type_end = data.index(b"\0", name_end + 1)
        size = int.from_bytes(data[type_end + 1:type_end + 5], "little")
        value = data[type_end + 5:type_end + 5 + size]
        if data[at:name_end] == b"dataWindow":
            x0, y0, x1, y1 = (int.from_bytes(value[i:i + 4], "little", signed=True) for i in range(0, 16, 4))
            return x1 - x0 + 1, y1 - y0 + 1
        at = type_end + 5 + size
    sys.exit(f"shot.py: {path} has no dataWindow")


def output(node, *names):
    """The node's first output among `names` (Blender names a multilayer image's passes)."""
    for name in names:
        if name in node.outputs and node.outputs[name].enabled:
            return node.outputs[name]
    sys.exit(f"shot.py: none of {names} among the image's outputs {[o.name for o in node.outputs]}")


def main():
    a = parse_args()
    scene = bpy.context.scene
    first = a.passes.replace("####", "0001")
    image = bpy.data.images.load(first, check_existing=False)
    image.source = "SEQUENCE"
    w, h = exr_size(first)  # Blender knows a multilayer image's size only once it composites
    # The Defocus node's f-stop for the thin lens (scripts/blender/defocus.py's docstring).
    f, s = a.focal_length, a.sensor_width
    n_b, lens = 1000.0 * a.fstop * s * max(w, h) / (s * s * w), f
    if n_b > F_STOP_MAX:
        n_b = F_STOP_MAX
        lens = f * math.sqrt(F_STOP_MAX * s * w / (1000.0 * a.fstop * max(w, h)))
    cam_data = bpy.data.cameras.new("realcam_match")
    cam_data.lens, cam_data.sensor_fit, cam_data.sensor_width = lens, "HORIZONTAL", s
    cam_data.dof.focus_distance = a.focus
    cam = bpy.data.objects.new("realcam_match", cam_data)
    scene.collection.objects.link(cam)
    scene.camera = cam

    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = w, h, 100
    r.use_compositing, r.use_sequencer = True, False
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "16"
    r.image_settings.color_mode = "RGBA"
    r.image_settings.exr_codec = "ZIP"  # realcam's default: half float, ZIP
    r.filepath = a.output
    r.use_file_extension = False
    scene.frame_start, scene.frame_end = 1, a.frames

    scene.use_nodes = True
    tree = scene.node_tree
    tree.nodes.clear()
    tree.render_quality = "HIGH"
    node = tree.nodes.new("CompositorNodeImage")
    node.image = image
    node.frame_duration, node.frame_start, node.frame_offset = a.frames, 1, 0
    d = tree.nodes.new("CompositorNodeDefocus")
    d.use_zbuffer, d.f_stop, d.blur_max, d.bokeh = True, n_b, a.blur_max, BOKEH[a.blades]
    d.use_gamma_correction, d.use_preview = False, False
    v = tree.nodes.new("CompositorNodeVecBlur")
    v.samples, v.factor, v.speed_min, v.speed_max, v.use_curved = 32, a.shutter, 0, 0, False
    comp = tree.nodes.new("CompositorNodeComposite")
    comp.use_alpha = True
    combined, depth = output(node, "Combined", "Image"), output(node, "Depth", "Z")
    if a.no_defocus:
        tree.nodes.remove(d)
        tree.links.new(combined, v.inputs["Image"])
    else:
        tree.links.new(combined, d.inputs["Image"])
        tree.links.new(depth, d.inputs["Z"])
        tree.links.new(d.outputs["Image"], v.inputs["Image"])
    tree.links.new(depth, v.inputs["Z"])
    tree.links.new(output(node, "Vector", "Speed"), v.inputs["Speed"])
    tree.links.new(v.outputs["Image"], comp.inputs["Image"])
    defocus = "no Defocus" if a.no_defocus else f"Defocus f_stop {n_b:.2f} (f/{a.fstop})"
    print(f"shot.py: {a.frames} frames of {w}x{h}, {defocus}, Vector Blur factor {a.shutter}", flush=True)
    bpy.ops.render.render(animation=True)


main()
