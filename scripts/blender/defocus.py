"""Blender's Defocus compositor node on a colour pass and a planar depth pass, written as an EXR.

Run by scripts/compare-blender.sh as
  blender -b --factory-startup -noaudio --python-exit-code 1 --python defocus.py -- \
      --color C.exr --depth D.exr --output OUT.exr --fstop 2 --focus 2 [options]
Checked with Blender 3.4.1 (Debian 12). Nothing is rendered: the node tree has no Render Layers
node, so Blender only composites (image nodes -> Defocus -> Composite) and writes the file.

How the f-number is matched (Blender's CoC, read from its source; Blender 3.x,
compositor/operations/COM_ConvertDepthToRadiusOperation.cc). With the scene camera's lens L (mm),
its sensor size s_b (mm, the width for horizontal or auto fit), the camera's focus distance S and
the Z pass z (scene units, here metres), the node's f-stop N_b, and the image's short side h and
long side w (aspect = h / w), the node computes the blur radius in pixels
    a      = 0.5 * L / (aspect * s_b) / N_b
    dof_sp = h / ((s_b / 2) / L) = 2 L h / s_b
    radius = 0.5 * | a * (dof_sp * (1/S - 1/z) - 1) |,   clamped to [0, blur_max]
so the disc diameter is  D_b = (L^2 w / (s_b^2 N_b)) * |1/S - 1/z|  up to an offset of a pixels
(a < 0.03 px in these runs: negligible). L and s_b are in mm but S and z in metres: the node's
f-stop is not the lens's f-number.
The thin lens at the pinhole (Cycles; realcam --lens ideal --coc-model renderer), aperture
A = f/N: CoC on the sensor c = A f |z - S| / (z S); in pixels of pitch s / w_fit (f, s in mm,
w_fit = the pixels the sensor width spans, = w for a landscape frame with horizontal fit)
    D = (f^2 w_fit / (1000 N s)) * |1/S - 1/z|.
D_b = D for every z when
    N_b = 1000 * N * s * L^2 * w / (f^2 * s_b^2 * w_fit),
i.e. N_b = 1000 N / s with the true camera (L = f, s_b = s): 27.8 N for a 36 mm sensor
(f/2 -> 55.6, f/5.6 -> 155.6). The node's f-stop stops at 128, so when N_b would exceed 128 this
script sets N_b = 128 and gives the Blender camera (used by nothing else: nothing is rendered) the
shorter lens solved from the same equation, L = f * sqrt(128 * s * w_fit / (1000 * N * w))
(45.4 mm at f/5.6). That changes only a: the sub-pixel offset, and the width of the Gaussian
(sigma = min(128 a, blur_max) px: 2.8 px at f/2, 1.1 instead of 1.0 px at f/5.6) that the node
runs over the radius map before taking the smaller of the blurred and the sharp radius (its guard
against far radii spilling onto near pixels).
"""
import argparse
import math
import sys

import bpy

BOKEH = {0: "CIRCLE", 3: "TRIANGLE", 4: "SQUARE", 5: "PENTAGON", 6: "HEXAGON", 7: "HEPTAGON", 8: "OCTAGON"}
F_STOP_MAX = 128.0  # the Defocus node's hard limit on f_stop


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="defocus.py", description=__doc__.split("\n")[0])
    p.add_argument("--color", required=True, help="colour pass EXR (RGB/RGBA)")
    p.add_argument("--depth", required=True, help="depth pass EXR with a Z channel (planar, metres)")
    p.add_argument("--output", required=True, help="output EXR (32-bit float RGBA)")
    p.add_argument("--fstop", type=float, required=True, help="f-number N of the thin lens to match")
    p.add_argument("--focus", type=float, required=True, help="focus distance S in metres (planar)")
    p.add_argument("--focal-length", type=float, default=50.0, help="f in mm (default 50)")
    p.add_argument("--sensor-width", type=float, default=36.0, help="sensor width in mm, horizontal fit (default 36)")
    p.add_argument("--blades", type=int, default=6, help="aperture blades: 0 (circle) or 3..8 (default 6)")
    p.add_argument("--blade-rotation", type=float, default=0.0,
                   help="bokeh rotation in degrees; 0 puts corners at the top and bottom, as Cycles' rotation 0")
    p.add_argument("--blur-max", type=float, default=32.0,
                   help="largest blur RADIUS in px (default 32: realcam's default --max-coc of 64 px diameter)")
    p.add_argument("--threshold", type=float, default=1.0,
                   help="CoC radius in px below which a pixel stays sharp (the node's default, 1)")
    p.add_argument("--execution", choices=["TILED", "FULL_FRAME"], default="TILED")
    p.add_argument("--chunk-size", default="256", choices=["32", "64", "128", "256", "512", "1024"],
                   help="tile size of the tiled compositor (default 256, Blender's; see docs/compare-blender.md)")
    p.add_argument("--exr-codec", default="NONE", help="EXR compression of the output (default NONE: fastest)")
    return p.parse_args(argv)


def main():
    a = parse_args()
    if a.blades not in BOKEH:
        sys.exit(f"defocus.py: --blades {a.blades}: the Defocus node draws 0 (circle) or 3..8 blades")
    if a.fstop <= 0 or a.focus <= 0:
        sys.exit("defocus.py: --fstop and --focus must be positive")

    scene = bpy.context.scene
    color = bpy.data.images.load(a.color, check_existing=False)
    depth = bpy.data.images.load(a.depth, check_existing=False)
    depth.colorspace_settings.name = "Non-Color"
    w_img, h_img = color.size[0], color.size[1]
    if (w_img, h_img) != (depth.size[0], depth.size[1]) or w_img == 0:
        sys.exit(f"defocus.py: colour {tuple(color.size)} and depth {tuple(depth.size)} sizes differ or are empty "
                 "(a multilayer EXR is not supported: pass the colour and depth files)")
    long_side, fit_side = max(w_img, h_img), w_img  # horizontal fit: the sensor width spans the image width

    # The f-stop for Blender's node (module docstring): N_b = 1000 N s L^2 w / (f^2 s_b^2 w_fit).
    f, s = a.focal_length, a.sensor_width
    lens = f
    n_b = 1000.0 * a.fstop * s * long_side / (s * s * fit_side)
    if n_b > F_STOP_MAX:
        n_b = F_STOP_MAX
        lens = f * math.sqrt(F_STOP_MAX * s * fit_side / (1000.0 * a.fstop * long_side))

    cam_data = bpy.data.cameras.new("realcam_match")
    cam_data.lens = lens
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.sensor_width = s
    cam_data.dof.focus_object = None
    cam_data.dof.focus_distance = a.focus
    cam = bpy.data.objects.new("realcam_match", cam_data)
    scene.collection.objects.link(cam)
    scene.camera = cam

    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = w_img, h_img, 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.use_compositing, r.use_sequencer = True, False
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    r.image_settings.color_mode = "RGBA"
    r.image_settings.exr_codec = a.exr_codec
    r.filepath = a.output
    r.use_file_extension = False

    scene.use_nodes = True
    tree = scene.node_tree
    tree.nodes.clear()
    tree.execution_mode = a.execution
    tree.chunk_size = a.chunk_size
    tree.render_quality = "HIGH"  # step 1 in the gather: every neighbour is read
    tree.use_opencl = False
    n_color = tree.nodes.new("CompositorNodeImage")
    n_color.image = color
    n_depth = tree.nodes.new("CompositorNodeImage")
    n_depth.image = depth  # a Z channel loads as the image's depth buffer: the "Depth" socket
    d = tree.nodes.new("CompositorNodeDefocus")
    d.use_zbuffer = True  # the Z input is depth, converted to a radius by the formula above
    d.f_stop = n_b
    d.blur_max = a.blur_max
    d.threshold = a.threshold
    d.bokeh = BOKEH[a.blades]
    d.angle = math.radians(a.blade_rotation)
    d.use_gamma_correction = False  # linear input: blur radiance, not gamma-encoded values
    d.use_preview = False  # preview forces the node's low quality (a gather step of 4)
    comp = tree.nodes.new("CompositorNodeComposite")
    comp.use_alpha = True
    tree.links.new(n_color.outputs["Image"], d.inputs["Image"])
    tree.links.new(n_depth.outputs["Depth"], d.inputs["Z"])
    tree.links.new(d.outputs["Image"], comp.inputs["Image"])

    print(f"defocus.py: N={a.fstop} -> node f_stop {n_b:.4f}, camera lens {lens:.4f} mm, sensor {s} mm, "
          f"focus {a.focus} m, blur_max {a.blur_max} px radius, threshold {a.threshold}, "
          f"{BOKEH[a.blades].lower()}, {a.execution.lower()} compositor", flush=True)
    bpy.ops.render.render(write_still=True)


main()
