//! `realcam accuracy`: every depth-of-field method on the user's own frame, against the
//! diffraction reference (Potmesil & Chakravarty's focus processor): GPU time per pass, RMSE,
//! PSNR, energy error and the perceptual FLIP difference, as Markdown, CSV and an SVG plot of
//! error against time. "Show what accuracy costs in time." Then the local fidelity, what a
//! compositor sees first, against `--bokeh reference` (the geometric full gather): the share of
//! 16-px tiles whose mean luminance is off by more than 5%, the worst tile, FLIP and the alpha
//! (src/tools/metrics.rs [`local_fidelity`]); with a ground truth, the same against it.

use crate::gpu::{Gpu, GpuResult, Profile};
use crate::model::camera::{BokehMode, Camera};
use crate::model::frame::Frame;
use crate::pipeline::planner::{plan, Plan};
use crate::pipeline::render::Renderer;
use crate::tools::error_budget::{budget, classify, RegionError};
use crate::tools::metrics::{
    compare_rgba, local_fidelity, local_fidelity_legend, ImageError, LocalFidelity, MATCHED_CLAMP,
};

/// One method's result.
#[derive(Clone, Debug)]
pub struct MethodResult {
    pub method: String,
    /// GPU time of the depth-of-field passes (upload, download and the other passes excluded).
    pub dof_ms: f64,
    pub profile: Profile,
    pub error: ImageError,
    /// Mean FLIP error (0 identical .. 1) of the sRGB previews (values clamped to [0, 1]).
    pub flip_mean: f64,
    /// Tiles off, worst tile and FLIP against `--bokeh reference` (the geometric full gather,
    /// [`GEOMETRIC`]); the alpha against the input's.
    pub local: LocalFidelity,
}

/// The method the local fidelity is judged against: realcam's `--bokeh reference`.
pub const GEOMETRIC: &str = "geometric full gather (--bokeh reference)";

/// A method to run: a name, the bokeh mode and how to adjust the plan (quality settings).
struct Method {
    name: String,
    mode: BokehMode,
    adjust: Box<dyn Fn(&mut Plan)>,
}

fn methods() -> Vec<Method> {
    let mut list = vec![
        Method { name: "diffraction (reference)".into(), mode: BokehMode::Diffraction, adjust: Box::new(|_| ()) },
        Method { name: GEOMETRIC.into(), mode: BokehMode::Reference, adjust: Box::new(|_| ()) },
        Method { name: "tiled (default settings)".into(), mode: BokehMode::Tiled, adjust: Box::new(|_| ()) },
    ];
    // The tiled path's quality setting: the CoC radius up to which it gathers exactly at full
    // resolution (beyond it, on the pyramid).
    for small_radius_px in [1.0f32, 2.0, 3.0, 4.0, 8.0] {
        list.push(Method {
            name: format!("tiled, exact up to {small_radius_px} px"),
            mode: BokehMode::Tiled,
            adjust: Box::new(move |p: &mut Plan| {
                for t in p.params_mut::<crate::passes::dof::tiled::TiledDof>() {
                    t.small_radius_px = small_radius_px;
                }
            }),
        });
    }
    list
}

fn dof_ms(profile: &Profile) -> f64 {
    let skip = ["upload", "download", "vignette", "film", crate::passes::film::WITH_VIGNETTE_NAME, "coc"];
    profile.passes.iter().filter(|p| !skip.contains(&p.name.as_str())).map(|p| p.gpu_ms).sum()
}

pub use crate::tools::metrics::flip_mean;

/// Run every method on `frame` with `camera` (its bokeh mode is replaced per method; exposure,
/// vignetting and film stay as set, so use a linear, unexposed camera to compare the blur alone).
pub fn run(gpu: &Gpu, frame: &Frame, camera: &Camera, mut progress: impl FnMut(&str)) -> GpuResult<Vec<MethodResult>> {
    let mut outputs = Vec::new();
    for m in methods() {
        progress(&m.name);
        let mut camera = camera.clone();
        camera.bokeh = m.mode;
        let mut p = plan(frame, &camera);
        (m.adjust)(&mut p);
        let renderer = Renderer::new(gpu, &p)?;
        // A warm-up run, so pipeline creation and first-touch costs are not timed.
        renderer.render(frame, &p, false)?;
        let out = renderer.render(frame, &p, false)?;
        outputs.push((m.name, out));
    }
    let reference = outputs[0].1.rgba.clone();
    let geometric = outputs[1].1.rgba.clone();
    Ok(outputs
        .into_iter()
        .map(|(method, out)| MethodResult {
            method,
            dof_ms: dof_ms(&out.profile),
            error: compare_rgba(&out.rgba, &reference),
            flip_mean: flip_mean(&out.rgba, &reference, frame.width, frame.height),
            local: local_fidelity(&out.rgba, &geometric, &frame.color, frame.width, frame.height),
            profile: out.profile,
        })
        .collect())
}

/// A method's error against ray-traced ground truth, with where it comes from.
#[derive(Clone, Debug)]
pub struct GroundTruthResult {
    pub method: String,
    /// GPU time of the depth-of-field passes (0 for the pinhole input).
    pub dof_ms: f64,
    pub error: ImageError,
    pub budget: Vec<RegionError>,
    /// Tiles off, worst tile and FLIP against the ground truth; the alpha against the input's.
    pub local: LocalFidelity,
    /// The same against `--bokeh reference` (None for the reference itself and the input).
    pub local_vs_reference: Option<LocalFidelity>,
}

/// The pinhole input and the tiled and reference depth of field of `camera` on `frame`, each
/// against `ground_truth` (RGBA of the frame's size): the energy-matched clamped RMSE and its
/// error budget ([`crate::tools::error_budget`]).
pub fn against_ground_truth(
    gpu: &Gpu,
    frame: &Frame,
    camera: &Camera,
    ground_truth: &[f32],
    mut progress: impl FnMut(&str),
) -> GpuResult<Vec<GroundTruthResult>> {
    let mut outputs = vec![("pinhole input".to_string(), frame.color.clone(), 0.0)];
    let mut coc_px = None;
    for (name, mode) in [("tiled", BokehMode::Tiled), ("reference", BokehMode::Reference)] {
        progress(name);
        let mut camera = camera.clone();
        camera.bokeh = mode;
        let p = plan(frame, &camera);
        let renderer = Renderer::new(gpu, &p)?;
        renderer.render(frame, &p, false)?;
        let out = renderer.render(frame, &p, true)?;
        coc_px = coc_px.or(out.coc_px);
        outputs.push((name.to_string(), out.rgba, dof_ms(&out.profile)));
    }
    let coc_px = coc_px.unwrap_or_else(|| vec![0.0; frame.depth_m.len()]);
    let regions = classify(frame.width, frame.height, &frame.color, &frame.depth_m, &coc_px);
    let reference = outputs[2].1.clone();
    let (w, h) = (frame.width, frame.height);
    Ok(outputs
        .into_iter()
        .map(|(method, rgba, dof_ms)| GroundTruthResult {
            dof_ms,
            error: compare_rgba(&rgba, ground_truth),
            budget: budget(&rgba, ground_truth, &regions),
            local: local_fidelity(&rgba, ground_truth, &frame.color, w, h),
            local_vs_reference: (method == "tiled").then(|| local_fidelity(&rgba, &reference, &frame.color, w, h)),
            method,
        })
        .collect())
}

/// The ground-truth comparison as Markdown.
pub fn ground_truth_markdown(device: &str, command: &str, results: &[GroundTruthResult]) -> String {
    let mut out = format!(
        "Device: {device}\n\nCommand: `{command}`\n\nErrors against the ray-traced ground truth: RMSE after matching the \
         total energy, values clamped to [0, {MATCHED_CLAMP}]; the share of the squared error (and the share of the pixels) in each \
         region of src/tools/error_budget.rs. GPU ms of the depth-of-field passes, from timestamp queries.\n\n"
    );
    out += "| method | GPU ms | RMSE (matched, clamped) | highlights | occlusion edges | smooth | energy |\n";
    out += "| --- | --- | --- | --- | --- | --- | --- |\n";
    for r in results {
        let shares: Vec<String> = r
            .budget
            .iter()
            .map(|b| {
                format!(
                    "{:.0}% of the error ({:.1}% of the pixels, RMSE {:.4})",
                    100.0 * b.error_share,
                    100.0 * b.pixel_share,
                    b.rmse
                )
            })
            .collect();
        out += &format!(
            "| {} | {:.1} | {:.4} | {} | {:+.3}% |\n",
            r.method,
            r.dof_ms,
            r.error.rmse_matched,
            shares.join(" | "),
            100.0 * r.error.relative_energy_error
        );
    }
    out += "\nLocal fidelity against the ground truth (tiled also against `--bokeh reference`). ";
    out += &local_fidelity_legend();
    out +=
        "\n\n| method | against | tiles off > 5% | worst tile | FLIP | alpha min | alpha < 0.999 where input is 1 |\n";
    out += "| --- | --- | --- | --- | --- | --- | --- |\n";
    for r in results {
        out += &local_row(&r.method, "ground truth", &r.local);
        if let Some(l) = &r.local_vs_reference {
            out += &local_row(&r.method, "--bokeh reference", l);
        }
    }
    out
}

/// A row of the local-fidelity tables: method, what it is against, then the measures.
fn local_row(method: &str, against: &str, l: &LocalFidelity) -> String {
    let worst = l.tiles.worst.map_or("-".into(), |w| {
        format!(
            "{:+.1}% at tile ({}, {}) = px ({}, {}): {:.4} vs {:.4}",
            100.0 * w.relative_error,
            w.tile.0,
            w.tile.1,
            w.x,
            w.y,
            w.test_mean,
            w.reference_mean
        )
    });
    format!(
        "| {method} | {against} | {:.1}% ({}/{}) | {worst} | {:.4} | {:.4} | {} of {} |\n",
        100.0 * l.tiles.share_off(),
        l.tiles.tiles_off,
        l.tiles.tiles,
        l.flip_mean,
        l.alpha.min,
        l.alpha.holes,
        l.alpha.opaque_in
    )
}

pub fn markdown(device: &str, command: &str, results: &[MethodResult]) -> String {
    let mut out = format!(
        "Device: {device}\n\nCommand: `{command}`\n\nErrors against the diffraction reference (RGB; the display RMSE clamps values to [0,1]; FLIP on the sRGB previews, 0 = identical). GPU ms of the depth-of-field passes, from timestamp queries.\n\n"
    );
    out += "| method | GPU ms | RMSE | display RMSE | PSNR dB | energy | FLIP |\n| --- | --- | --- | --- | --- | --- | --- |\n";
    for r in results {
        out += &format!(
            "| {} | {:.1} | {:.5} | {:.5} | {:.1} | {:+.3}% | {:.4} |\n",
            r.method,
            r.dof_ms,
            r.error.rmse,
            r.error.rmse_display,
            r.error.psnr_db,
            100.0 * r.error.relative_energy_error,
            r.flip_mean
        );
    }
    out += "\nGPU ms per pass:\n\n";
    for r in results {
        let passes: Vec<String> = r
            .profile
            .passes
            .iter()
            .filter(|p| p.name != "upload" && p.name != "download")
            .map(|p| format!("{} {:.2}", p.name, p.gpu_ms))
            .collect();
        out += &format!("- {}: {}\n", r.method, passes.join(", "));
    }
    out += "\nLocal fidelity against `--bokeh reference` (the geometric full gather): what a compositor sees first. ";
    out += &local_fidelity_legend();
    out +=
        "\n\n| method | against | tiles off > 5% | worst tile | FLIP | alpha min | alpha < 0.999 where input is 1 |\n";
    out += "| --- | --- | --- | --- | --- | --- | --- |\n";
    for r in results {
        out += &local_row(&r.method, "--bokeh reference", &r.local);
    }
    out
}

pub fn csv(results: &[MethodResult]) -> String {
    let mut out = String::from(
        "method,gpu_ms,rmse,display_rmse,psnr_db,energy_error,flip_mean,tiles_off_share,tiles_off,tiles,worst_tile_x,worst_tile_y,worst_tile_error,flip_vs_geometric,alpha_min,alpha_holes\n",
    );
    for r in results {
        let l = &r.local;
        let (wx, wy, we) = l.tiles.worst.map_or((0, 0, 0.0), |w| (w.x, w.y, w.relative_error));
        out += &format!(
            "\"{}\",{:.4},{:.6},{:.6},{:.3},{:.6},{:.6},{:.6},{},{},{wx},{wy},{we:.6},{:.6},{:.6},{}\n",
            r.method.replace('"', "'"),
            r.dof_ms,
            r.error.rmse,
            r.error.rmse_display,
            r.error.psnr_db,
            r.error.relative_energy_error,
            r.flip_mean,
            l.tiles.share_off(),
            l.tiles.tiles_off,
            l.tiles.tiles,
            l.flip_mean,
            l.alpha.min,
            l.alpha.holes
        );
    }
    out
}

/// Error (FLIP) against GPU time, log time axis, one labelled point per method.
pub fn svg(device: &str, results: &[MethodResult]) -> String {
    let (w, h, margin) = (720.0, 440.0, 70.0);
    let times: Vec<f64> = results.iter().map(|r| r.dof_ms.max(1e-3).log10()).collect();
    let (t0, t1) = times.iter().fold((f64::MAX, f64::MIN), |(a, b), &t| (a.min(t), b.max(t)));
    let (t0, t1) = (t0.floor(), t1.ceil().max(t0.floor() + 1.0));
    let e1 = results.iter().map(|r| r.flip_mean).fold(0.0, f64::max).max(1e-3) * 1.15;
    let x = |t: f64| margin + (t - t0) / (t1 - t0) * (w - 2.0 * margin);
    let y = |e: f64| h - margin - e / e1 * (h - 2.0 * margin);
    let mut out = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
    );
    out += &format!("<text x=\"{}\" y=\"24\" text-anchor=\"middle\" font-size=\"14\">Depth-of-field error against GPU time ({})</text>\n", w / 2.0, xml(device));
    out += &format!(
        "<line x1=\"{margin}\" y1=\"{0}\" x2=\"{1}\" y2=\"{0}\" stroke=\"black\"/>\n<line x1=\"{margin}\" y1=\"{margin}\" x2=\"{margin}\" y2=\"{0}\" stroke=\"black\"/>\n",
        h - margin,
        w - margin
    );
    let mut decade = t0;
    while decade <= t1 + 1e-9 {
        out += &format!(
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{} ms</text>\n",
            x(decade),
            h - margin + 18.0,
            10f64.powf(decade)
        );
        decade += 1.0;
    }
    for i in 0..=4 {
        let e = e1 * i as f64 / 4.0;
        out += &format!("<text x=\"{}\" y=\"{}\" text-anchor=\"end\">{e:.3}</text>\n", margin - 6.0, y(e) + 4.0);
    }
    out += &format!(
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">GPU time of the depth of field (log)</text>\n",
        w / 2.0,
        h - 20.0
    );
    out += &format!("<text x=\"18\" y=\"{}\" transform=\"rotate(-90 18 {})\" text-anchor=\"middle\">mean FLIP vs diffraction</text>\n", h / 2.0, h / 2.0);
    for (r, t) in results.iter().zip(&times) {
        out += &format!(
            "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"4\" fill=\"#2a6fdb\"/><text x=\"{:.1}\" y=\"{:.1}\">{}</text>\n",
            x(*t),
            y(r.flip_mean),
            x(*t) + 7.0,
            y(r.flip_mean) - 6.0,
            xml(&r.method)
        );
    }
    out + "</svg>\n"
}

fn xml(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}
