"""The Python package against the command line: the same pixels, the same errors, one device.

Run by scripts/test.sh in a virtual environment after `maturin develop --release`; REALCAM_BIN
names the command line to compare with (default: the repository's target/release or
target/debug build). Every render runs with the Khronos validation layer and synchronization
validation (a validation message makes the render raise).
"""

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import realcam

ROOT = Path(__file__).resolve().parents[2]
TESTDATA = ROOT / "testdata"


def cli_binary():
    if os.environ.get("REALCAM_BIN"):
        return os.environ["REALCAM_BIN"]
    built = [ROOT / "target" / p / "realcam" for p in ("release", "debug")]
    built = [b for b in built if b.exists()]
    if not built:
        pytest.fail("no realcam binary: build it (cargo build --release) or set REALCAM_BIN")
    return str(max(built, key=lambda b: b.stat().st_mtime))


def cli(*args):
    env = dict(os.environ, REALCAM_VALIDATE="1")
    return subprocess.run([cli_binary(), *map(str, args)], capture_output=True, text=True, env=env)


def cli_error(*args):
    """The command line's error message (its last stderr line without `error: `)."""
    run = cli(*args)
    assert run.returncode == 1, run.stderr
    last = run.stderr.strip().splitlines()[-1]
    assert last.startswith("error: "), run.stderr
    return last[len("error: "):]


# Scenes of testdata/: a defocused highlight (depth of field, flare, vignette, film), and a crop
# of Blender scene A with its Vector pass (motion blur before the depth of field).
CASES = [
    ("point_bg", ["--depth", TESTDATA / "point_bg_depth.exr"], dict(fstop=2, focus=2)),
    ("sceneA_mover", [], dict(lens="ideal", fstop=2.8, focus=2, blades=6, film="linear", fps=24, shutter_angle=180)),
]


@pytest.mark.parametrize("name,inputs,settings", CASES, ids=[c[0] for c in CASES])
def test_numpy_round_trip_is_bit_identical_to_the_cli(tmp_path, name, inputs, settings):
    color = TESTDATA / (f"{name}_color.exr" if inputs else f"{name}_passes.exr")
    out = tmp_path / "cli.exr"
    flags = []
    for key, value in settings.items():
        flags.append(f"--{key.replace('_', '-')}={value}")
    run = cli("render", "--color", color, *inputs, *flags, "--float", "-o", out)
    assert run.returncode == 0, run.stderr

    read_flags = {"depth": str(inputs[1])} if inputs else {}
    passes = realcam.read_passes(str(color), **read_flags)
    assert passes["color"].dtype == np.float32 and passes["color"].shape[2] == 4
    assert passes["depth"].shape == passes["color"].shape[:2]
    if name == "sceneA_mover":
        # Blender's Vector pass, read as px per frame toward the next frame, x right, y down.
        assert passes["velocity"].shape == passes["color"].shape[:2] + (2,)
        assert np.abs(passes["velocity"]).max() > 1.0
    camera = realcam.Camera(validate=True, **settings)
    image = camera.render(**passes)

    expected = realcam.read_exr(str(out))
    assert image.dtype == np.float32 and image.shape == expected.shape
    assert np.array_equal(image.view(np.uint32), expected.view(np.uint32)), (
        f"{np.count_nonzero(image != expected)} values differ from the CLI's"
    )


def test_the_plan_and_gpu_times_of_a_render():
    passes = realcam.read_passes(str(TESTDATA / "point_bg_color.exr"), depth=str(TESTDATA / "point_bg_depth.exr"))
    camera = realcam.Camera(validate=True, fstop=2, focus=2)
    camera.render(**passes)
    plan = {name: (runs, why) for name, runs, why in camera.plan}
    assert plan["motion_blur"] == (False, "no velocity pass")
    assert plan["coc"][0] and "at f/2 focused at 2 m" in plan["coc"][1]
    assert "[run ] coc" in camera.explain
    # The vignette runs in the film's dispatch (one read and write of the frame fewer).
    assert plan["vignette"][0] and "applied in the film pass's dispatch" in plan["vignette"][1]
    times = dict(camera.profile)
    assert set(times) >= {"upload", "coc", "vignette+film", "download"}
    assert "vignette" not in times and "film" not in times
    assert all(ms >= 0.0 for ms in times.values()) and times["coc"] > 0.0


def test_the_device_and_pipelines_are_kept_across_renders():
    passes = realcam.read_passes(str(TESTDATA / "point_fg_color.exr"), depth=str(TESTDATA / "point_fg_depth.exr"))
    camera = realcam.Camera(validate=True, fstop=2, focus=2)
    assert camera.device is None and camera.gpu_opens == 0
    first = camera.render(**passes)
    device = camera.device
    # Later frames on the same device, with the same pipelines.
    for _ in range(2):
        again = camera.render(**passes)
    assert camera.gpu_opens == 1 and camera.device == device
    assert np.array_equal(first, again)


def test_bad_inputs_raise_the_cli_messages(tmp_path):
    missing = tmp_path / "missing.exr"
    with pytest.raises(realcam.RealcamError) as e:
        realcam.read_passes(str(missing))
    assert str(e.value) == cli_error("render", "--color", missing, "-o", tmp_path / "o.exr")
    assert str(e.value) == f'color: file "{missing}" does not exist'

    # A setting outside the lens file's range: the CLI's message, flag included.
    with pytest.raises(realcam.RealcamError) as e:
        realcam.Camera(fstop=1.0)
    color = TESTDATA / "point_bg_color.exr"
    assert str(e.value) == cli_error("render", "--color", color, "--fstop", "1.0", "-o", tmp_path / "o.exr")
    assert str(e.value).endswith("; pass --force to use it anyway")

    with pytest.raises(TypeError, match="unexpected argument '--fstp' found"):
        realcam.Camera(fstp=2)


def test_bad_arrays_are_named():
    camera = realcam.Camera(fstop=2, focus=2)
    color = np.zeros((4, 6, 4), np.float32)
    depth = np.full((4, 6), 2.0, np.float32)
    depth[2, 3] = np.nan
    depth[3, 0] = -1.0
    with pytest.raises(realcam.RealcamError) as e:
        camera.render(color, depth)
    assert str(e.value) == (
        "depth: the array has 2 invalid pixel(s) (NaN or negative depth); the first is pixel (x=3, y=2) with NaN m"
    )
    with pytest.raises(realcam.RealcamError) as e:
        camera.render(color, np.ones((4, 5), np.float32))
    assert str(e.value) == "size mismatch: color is 6x4 px but depth is 5x4 px (the arrays must have the same size)"
    with pytest.raises(realcam.RealcamError) as e:
        camera.render(np.zeros((4, 6), np.float32), depth)
    assert str(e.value) == "color: an array of shape (H, W, 4) or (H, W, 3) is expected, got shape [4, 6]"
    assert camera.gpu_opens == 0


def test_hdr_and_nan_colour_stay_finite():
    color = np.zeros((24, 32, 4), np.float32)
    color[..., 3] = 1.0
    color[10, 10, :3] = 1e6
    color[3, 4, 0] = np.nan
    color[5, 6, 1] = np.inf
    depth = np.full((24, 32), 0.5, np.float32)
    depth[:, 16:] = np.inf
    camera = realcam.Camera(validate=True, fstop=2, focus=2, film="linear", no_exposure=True, no_flare=True)
    image = camera.render(color, depth)
    assert np.isfinite(image).all()
    # The highlight's light is kept (energy within 0.5% over the frame, vignetting off).
    camera = realcam.Camera(validate=True, fstop=2, focus=2, film="linear", no_exposure=True, no_vignetting=True, no_flare=True)
    image = camera.render(color, depth)
    clean = np.nan_to_num(color, nan=0.0, posinf=0.0)
    assert abs(image[..., :3].sum() / clean[..., :3].sum() - 1.0) < 5e-3


def test_settings_change_per_frame_on_one_device():
    """A rack focus from Python (issue 31, item 7): `set` and a render's own keywords change
    the camera; the device and pipelines stay."""
    passes = realcam.read_passes(str(TESTDATA / "point_bg_color.exr"), depth=str(TESTDATA / "point_bg_depth.exr"))
    camera = realcam.Camera(validate=True, fstop=2, focus=2, film="linear", no_exposure=True, no_flare=True)
    at_2m = camera.render(**passes)
    camera.set(focus=3)
    at_3m = camera.render(**passes)
    assert not np.array_equal(at_2m, at_3m)
    # A render's own keyword holds for that render only.
    assert np.array_equal(camera.render(**passes, focus=2), at_2m)
    assert np.array_equal(camera.render(**passes), at_3m)
    # None removes a setting: the default focus, 2 m.
    camera.set(focus=None)
    assert np.array_equal(camera.render(**passes), at_2m)
    assert camera.gpu_opens == 1


def test_a_camera_file_gives_each_frame_its_setting(tmp_path):
    passes = realcam.read_passes(str(TESTDATA / "point_bg_color.exr"), depth=str(TESTDATA / "point_bg_depth.exr"))
    rack = tmp_path / "rack.toml"
    rack.write_text("[focus_distance_m]\ninterpolation = \"linear\"\nkeys = [[10, 2.0], [20, 3.0]]\n")
    fixed = dict(validate=True, fstop=2, film="linear", no_exposure=True, no_flare=True)
    keyed = realcam.Camera(camera_file=str(rack), **fixed)
    for frame, focus in [(10, 2), (20, 3)]:
        expected = realcam.Camera(focus=focus, **fixed).render(**passes, frame=frame)
        assert np.array_equal(keyed.render(**passes, frame=frame), expected)


def test_float16_and_float64_arrays_are_converted_and_others_named():
    passes = realcam.read_passes(str(TESTDATA / "point_fg_color.exr"), depth=str(TESTDATA / "point_fg_depth.exr"))
    camera = realcam.Camera(fstop=2, focus=2)
    # float64 holds every float32 exactly; float16 is converted exactly to float32 (1.2 m becomes
    # 1.2001953 m either way).
    depth16 = passes["depth"].astype(np.float16)
    expected = camera.render(passes["color"], depth16.astype(np.float32))
    image = camera.render(passes["color"].astype(np.float64), depth16)
    assert np.array_equal(image, expected)
    with pytest.raises(TypeError) as e:
        camera.render(passes["color"].astype(np.int32), passes["depth"])
    assert str(e.value) == "color: an array of float32 (or float16, float64, converted) is expected, got int32"


def test_render_file_writes_what_the_cli_writes(tmp_path):
    color, depth = TESTDATA / "point_bg_color.exr", TESTDATA / "point_bg_depth.exr"
    cli_out = tmp_path / "cli.exr"
    run = cli("render", "--color", color, "--depth", depth, "--fstop", "2", "--focus", "2", "--float", "-o", cli_out)
    assert run.returncode == 0, run.stderr
    camera = realcam.Camera(validate=True, fstop=2, focus=2, float=True)
    out = tmp_path / "py.exr"
    assert camera.render_file(str(color), str(out), depth=str(depth), png=str(tmp_path / "py.png")) == [
        str(out),
        str(tmp_path / "py.png"),
    ]
    assert np.array_equal(realcam.read_exr(str(out)), realcam.read_exr(str(cli_out)))
    # Never over an input.
    with pytest.raises(realcam.RealcamError) as e:
        camera.render_file(str(color), str(depth), depth=str(depth))
    assert "depth pass" in str(e.value)


def test_the_gpu_works_without_the_gil():
    """Another Python thread runs while a render is on the GPU (lavapipe: on the CPU)."""
    import threading
    import time

    color = np.zeros((384, 512, 4), np.float32)
    color[..., :3] = np.random.default_rng(1).random((384, 512, 3), np.float32)
    color[..., 3] = 1
    depth = np.full((384, 512), 9.0, np.float32)
    camera = realcam.Camera(fstop=1.4, focus=0.5, bokeh="reference")
    camera.render(color, depth)  # the device and pipelines opened
    ticks, stop = [], threading.Event()

    def tick():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    thread = threading.Thread(target=tick)
    thread.start()
    time.sleep(0.02)
    start = time.perf_counter()
    camera.render(color, depth)
    end = time.perf_counter()
    stop.set()
    thread.join()
    inside = [t for t in ticks if start + 0.01 < t < end - 0.01]
    assert end - start > 0.05, "the render was too quick to tell"
    assert len(inside) >= 3, f"{len(inside)} ticks during a render of {end - start:.3f} s"


def test_a_frame_beyond_the_gpu_memory_given_renders_in_bands_with_the_same_pixels():
    # The README demo at f/2 (depth of field, flare, the film, grain) on 30 MB of GPU memory,
    # where it needs about 47: the frame in bands (as the command line's test shows with
    # --explain), the pixels of the whole frame's render. On 2 MB not one row of tiles with its
    # aprons fits: the command line's message.
    passes = realcam.read_passes(str(TESTDATA / "demo_color.exr"), depth=str(TESTDATA / "demo_depth.exr"))
    settings = dict(fstop=2, focus=2, grain=0.05)
    whole = realcam.Camera(validate=True, **settings).render(**passes)
    banded = realcam.Camera(validate=True, max_gpu_memory="30M", **settings).render(**passes)
    assert np.array_equal(whole, banded)
    with pytest.raises(realcam.RealcamError, match="a band of 640 px by one tile row with aprons of"):
        realcam.Camera(validate=True, max_gpu_memory="2M", **settings).render(**passes)
