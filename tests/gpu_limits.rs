//! The device's resources: what it cannot hold is an error naming it, before Vulkan is asked
//! (lavapipe in CI, validation on: creating such an image would be invalid usage); what a frame
//! let go of serves the next frame of the same size.

mod support;

use ash::vk;
use realcam::pipeline::planner::plan;
use realcam::pipeline::render::Renderer;
use support::{assert_validation_clean, dof_camera, gpu, motion_camera, moving_bar_frame};

#[test]
fn an_image_beyond_the_device_limit_is_an_error_naming_it() {
    let gpu = gpu();
    let mut rec = realcam::gpu::Recorder::new(&gpu, "limits test").unwrap();
    // An image of exactly the limit's width (one row) is fine; one more pixel is not.
    let max_px = gpu.max_image_dimension_px();
    rec.create_image("widest", max_px, 1, vk::Format::R32_SFLOAT).unwrap();
    let err = match rec.create_image("aperture shape table", max_px + 1, max_px + 1, vk::Format::R32_SFLOAT) {
        Ok(_) => panic!("an image of {0}x{0} px was made", max_px + 1),
        Err(e) => e,
    };
    assert_eq!(
        err.to_string(),
        format!(
            "the image \"aperture shape table\" of {0}x{0} px does not fit the device {1:?}: its images may be at most {max_px} px on a side",
            max_px + 1,
            gpu.info().name
        )
    );
    drop(rec);
    assert_validation_clean(&gpu);
}

/// A `w` x `h` frame defocused at two depths (0.8 m left, 9 m right of the middle) with a
/// highlight (60, 50, 40) at every `every`-th pixel over a dim background.
fn highlights_over_two_depths(w: u32, h: u32, every: u32) -> realcam::model::frame::Frame {
    let color: Vec<f32> =
        (0..w * h).flat_map(|i| if i % every == 0 { [60.0, 50.0, 40.0, 1.0] } else { [0.2, 0.3, 0.1, 1.0] }).collect();
    let depth: Vec<f32> = (0..w * h).map(|i| if (i % w) < w / 2 { 0.8 } else { 9.0 }).collect();
    realcam::model::frame::Frame::new(w, h, color, depth)
}

#[test]
fn the_next_frame_of_the_same_size_reuses_the_last_frames_images_and_buffers_and_gives_the_same_bits() {
    // A defocused frame with highlights (the tiled path's many images and buffers, counters
    // cleared per frame), rendered four times by one renderer: after the first every image and
    // buffer goes to the pool, the later frames take theirs from it (the pool holds as many
    // afterwards, none created anew), and the stale contents change no bit of the output.
    let gpu = gpu();
    let frame = highlights_over_two_depths(96, 64, 97);
    let camera = dof_camera(50.0, 1.4, 2.0, 6);
    let p = plan(&frame, &camera);
    assert!(p.runs("bokeh_tiled"), "{}", p.explain());
    let renderer = Renderer::new(&gpu, &p).expect("pipelines");
    assert_eq!(gpu.pool_idle().0, 0);
    let first = renderer.render(&frame, &p, false).expect("render").rgba;
    let after_first = gpu.pool_idle();
    assert!(after_first.0 > 20, "the pool after a frame: {after_first:?}");
    for run in 1..4 {
        let again = renderer.render(&frame, &p, false).expect("render").rgba;
        assert_eq!(gpu.pool_idle(), after_first, "run {run}: the pool grew or shrank");
        let differ = first.iter().zip(&again).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
        assert_eq!(differ, 0, "run {run}: values differ from the first frame's");
    }
    assert_validation_clean(&gpu);
    gpu.trim_pool();
    assert_eq!(gpu.pool_idle(), (0, 0));
}

#[test]
fn the_pipelines_created_before_the_frame_is_read_are_those_its_plan_uses() {
    // A session creates the pipelines of the passes the camera will likely run while the first
    // frame is still being read (Renderer::create_likely). For the tiled depth of field that is
    // every pipeline the plan uses: the CoC pass's (its specialisation is the camera's alone),
    // its edge resolve's where the camera resolves depth edges (coc_edges, specialised by the
    // camera's field curvature alone), the tiled path's nine unspecialised ones, and the five
    // the lens specialises (the two gathers, the composite with and without its exact gather,
    // and the sprites, each with or without the aberration's path); the plan adds none. A
    // likely pipeline the plan did not use, or a specialisation other than the plan's, shows as
    // a count off by one or five.
    let (w, h) = (64u32, 48u32);
    let color: Vec<f32> = (0..w * h).flat_map(|i| [0.2 + (i % 7) as f32 * 0.1, 0.3, 0.1, 1.0]).collect();
    let depth: Vec<f32> = (0..w * h).map(|i| if (i % w) < w / 2 { 0.8 } else { 9.0 }).collect();
    let frame = realcam::model::frame::Frame::new(w, h, color, depth);
    for (resolve_depth_edges, spherical_aberration) in [(true, 0.0), (false, 0.0), (true, 0.3)] {
        let mut camera = realcam::model::camera::Camera { resolve_depth_edges, ..dof_camera(50.0, 1.4, 2.0, 6) };
        camera.aperture.spherical_aberration = spherical_aberration;
        let p = plan(&frame, &camera);
        assert!(p.runs("coc") && p.runs("bokeh_tiled"), "{}", p.explain());

        let warm = gpu();
        let renderer = Renderer::empty(&warm);
        renderer.create_likely(&camera, false).expect("likely pipelines");
        let likely = warm.pipelines_created();
        renderer.prepare(&p).expect("the plan's pipelines");
        let added = warm.pipelines_created() - likely;
        let case = format!("resolve_depth_edges {resolve_depth_edges}, spherical aberration {spherical_aberration}");
        // coc, coc_edges with the resolve, and the tiled path's fourteen.
        let coc_pipelines = if resolve_depth_edges { 2 } else { 1 };
        assert_eq!((likely, added), (coc_pipelines + 14, 0), "{case}");
        renderer.render(&frame, &p, false).expect("render");
        assert_eq!(warm.pipelines_created(), likely + added, "{case}: the render created a pipeline the plan had not");
        assert_validation_clean(&warm);

        // Without the head start, the plan creates them all (sixteen, fifteen without the
        // resolve).
        let cold = gpu();
        Renderer::new(&cold, &p).expect("pipelines");
        assert_eq!(cold.pipelines_created(), coc_pipelines + 14);
    }
}

#[test]
fn the_motion_blurs_pipelines_are_created_before_the_frame_when_its_headers_name_velocity() {
    // The headers of the first frame's files say whether it likely holds a velocity pass
    // (io::velocity_likely): then the motion blur's six pipelines are created beside the read,
    // and the plan adds none;
    // without the hint the plan creates them after the read.
    let frame = moving_bar_frame(64, 48, (20, 30), [0.9, 0.4, 0.1], (1.0, 5.0), [6.0, 0.0], None, |x, _| {
        [0.1 + (x % 5) as f32 * 0.1, 0.3, 0.2]
    });
    let camera = motion_camera(24.0, 0.5);
    let p = plan(&frame, &camera);
    assert!(p.runs("motion_blur"), "{}", p.explain());
    for velocity in [true, false] {
        let warm = gpu();
        let renderer = Renderer::empty(&warm);
        renderer.create_likely(&camera, velocity).expect("likely pipelines");
        let likely = warm.pipelines_created();
        renderer.prepare(&p).expect("the plan's pipelines");
        let added = warm.pipelines_created() - likely;
        // The gather, the still tiles' copy, and the edge resolve's tiles, neighbours, list and
        // resolve.
        assert_eq!(added, if velocity { 0 } else { 6 }, "velocity hint {velocity}");
        renderer.render(&frame, &p, false).expect("render");
        assert_validation_clean(&warm);
    }
}

#[test]
fn on_a_device_that_runs_on_the_cpu_images_are_written_and_read_in_host_memory_frame_after_frame() {
    // The bare pass (upload, copy shader, read-back) on an odd-sized frame, three frames of
    // different values through one device: on lavapipe the upload is the host's write into
    // the image and the read-back the host's read out of the copy's image. The later frames
    // take images from the pool in whatever layout the last frame left them (GENERAL, not
    // PREINITIALIZED as new ones), so a wrong layout is a validation error, a wrong row pitch
    // or stale texels a changed value.
    use realcam::gpu::{Kernel, Recorder};
    use realcam::passes::copy::{self, CopyShader};
    use realcam::passes::FrameImages;
    let gpu = gpu();
    let kernel = Kernel::<CopyShader>::new(&gpu).unwrap();
    let (w, h) = (37u32, 5u32);
    for frame in 0..3 {
        let texels: Vec<f32> = (0..w * h * 4).map(|i| (i as f32) * 0.25 + frame as f32 * 1000.0).collect();
        let mut rec = Recorder::new(&gpu, "host memory test").unwrap();
        let color = rec.create_image("color (input)", w, h, vk::Format::R32G32B32A32_SFLOAT).unwrap();
        assert_eq!(color.in_host_memory(), gpu.info().on_cpu(), "frame {frame}");
        rec.upload_images(&[(&color, &texels)]).unwrap();
        let mut images = FrameImages::new(color, None);
        copy::record(&kernel, &mut rec, &mut images).unwrap();
        assert_eq!(images.color().in_host_memory(), gpu.info().on_cpu());
        let out = rec.download_image(images.color(), 4).unwrap();
        let (_, mut data) = rec.submit().unwrap();
        assert_eq!(std::mem::take(&mut data[out.index()]), texels, "frame {frame}");
    }
    assert_validation_clean(&gpu);
}

#[test]
fn a_render_taking_the_frames_colour_gives_the_same_bits_in_that_colours_memory() {
    // The command line gives up each frame's colour once it is uploaded: on a device that runs
    // on the CPU the result is read into the colour's own allocation (no fresh frame of pages),
    // and it is the same image as a render that keeps the frame.
    let gpu = gpu();
    let mut frame = highlights_over_two_depths(48, 32, 53);
    let camera = dof_camera(50.0, 1.4, 2.0, 6);
    let p = plan(&frame, &camera);
    let renderer = Renderer::new(&gpu, &p).expect("pipelines");
    let kept = renderer.render(&frame, &p, false).expect("render").rgba;
    let colour_at = frame.color.as_ptr();
    let taken = renderer.render_taking_colour(&mut frame, &p, false).expect("render").rgba;
    assert!(frame.color.is_empty(), "the frame kept its colour");
    assert_eq!(taken.len(), kept.len());
    let differ = kept.iter().zip(&taken).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
    assert_eq!(differ, 0, "values differ from the render that kept the frame");
    if gpu.info().on_cpu() {
        assert_eq!(taken.as_ptr(), colour_at, "the result is not in the colour's memory");
    }
    assert_validation_clean(&gpu);
}

#[test]
fn the_profile_reports_the_gpu_memory_a_frame_held_and_the_next_frame_holds_no_more() {
    // `--profile` and the bench report the device memory held at the submit (issue 33 item 2).
    // A frame's colour comes in and a new one goes out (RGBA32F, 16 bytes per pixel each), so
    // the tiled depth of field holds at least 32 bytes per pixel; a second frame of the same
    // size takes its images from the pool and holds no more than the first.
    let gpu = gpu();
    let (w, h) = (256u32, 160u32);
    let frame = highlights_over_two_depths(w, h, 97);
    let camera = dof_camera(50.0, 1.4, 2.0, 6);
    let p = plan(&frame, &camera);
    let renderer = Renderer::new(&gpu, &p).expect("pipelines");
    let first = renderer.render(&frame, &p, false).expect("render").profile;
    let second = renderer.render(&frame, &p, false).expect("render").profile;
    let per_px = |bytes: u64| bytes as f64 / (w * h) as f64;
    println!("{}; second frame {:.0} B/px", first.memory_line((w * h) as u64), per_px(second.gpu_memory_bytes));
    assert!(per_px(first.gpu_memory_bytes) >= 32.0, "{}", first.memory_line((w * h) as u64));
    assert!(
        second.gpu_memory_bytes <= first.gpu_memory_bytes,
        "{} then {}",
        first.gpu_memory_bytes,
        second.gpu_memory_bytes
    );
    assert_validation_clean(&gpu);
}
