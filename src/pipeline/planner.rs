//! Decides which passes a frame and camera call for, and says why (`--explain`). A pass whose
//! effect would be invisible is not recorded and its pipeline is never created.

use crate::model::camera::{BokehMode, Camera, FilmMode};
use crate::model::frame::Frame;
use crate::passes::bokeh_gather::GatherParams;
use crate::passes::coc::CocParams;
use crate::passes::film::FilmParams;
use crate::passes::tiled_dof::TiledDofParams;
use crate::passes::vignette::VignetteParams;

/// A CoC whose diameter is at most this many pixels is invisible.
pub const VISIBLE_COC_PX: f64 = 1.0;
/// Vignetting weaker than this relative falloff at the corners is invisible.
pub const VISIBLE_FALLOFF: f64 = 1.0e-4;

/// The plan's name for the tiled depth-of-field path (several passes, see `passes::tiled_dof`).
pub const BOKEH_TILED: &str = "bokeh_tiled";

/// One line of the plan.
#[derive(Clone, Debug)]
pub struct Step {
    pub pass: &'static str,
    pub run: bool,
    pub why: String,
}

/// The planned pipeline with the parameters of every pass that runs.
#[derive(Clone, Debug)]
pub struct Plan {
    pub steps: Vec<Step>,
    pub coc: Option<CocParams>,
    /// The reference gather (`--bokeh reference`).
    pub gather: Option<GatherParams>,
    /// The tiled path (`--bokeh tiled`, the default).
    pub tiled: Option<TiledDofParams>,
    /// The diffraction focus processor (`--bokeh diffraction`): its tables and push constants.
    pub diffraction: Option<(
        std::sync::Arc<crate::optics::focus_processor::PsfTables>,
        crate::passes::diffraction::DiffractionParams,
    )>,
    /// Distortion and lateral colour: push constants and the table buffer's data.
    pub distortion: Option<(crate::passes::distortion::DistortionParams, Vec<f32>)>,
    pub vignette: Option<VignetteParams>,
    /// Astigmatism: push constants and the table buffer's data.
    pub astigmatism: Option<(crate::passes::astigmatism::AstigmatismParams, Vec<f32>)>,
    /// Longitudinal colour: the red and blue channels' CoC offsets (px); the depth of field
    /// then runs once per channel.
    pub longitudinal_color_px: Option<[f32; 2]>,
    /// Coma: push constants and the table buffer's data.
    pub coma: Option<(crate::passes::coma::ComaParams, Vec<f32>)>,
    /// The CoC pass's field-curvature buffer (crate::passes::coc::table_data).
    pub coc_table: Vec<f32>,
    /// The vignette pass's table buffer (crate::passes::vignette::table_data).
    pub vignette_table: Vec<f32>,
    pub film: Option<FilmParams>,
    /// The film pass's table buffer (crate::passes::film::table_data).
    pub film_table: Vec<f32>,
    /// The aperture image's storage-buffer data ([0, 0] when none), src/model/aperture.rs.
    pub aperture_mask: Vec<f32>,
    /// Signed CoC range over the frame in pixels (after the user clamp).
    pub coc_range_px: (f64, f64),
}

impl Plan {
    pub fn runs(&self, pass: &str) -> bool {
        self.steps.iter().any(|s| s.pass == pass && s.run)
    }

    /// The plan as text: one line per pass, run or skipped, and why.
    pub fn explain(&self) -> String {
        let mut out = String::from("pass plan:\n");
        for s in &self.steps {
            out += &format!("  [{}] {:<13} {}\n", if s.run { "run " } else { "skip" }, s.pass, s.why);
        }
        out
    }
}

pub fn plan(frame: &Frame, camera: &Camera) -> Plan {
    let (w, h) = (frame.width, frame.height);
    let (dw, dh) = frame.display_size();
    let pitch_mm = camera.pixel_pitch_mm(dw, dh);
    let mut steps = Vec::new();

    // Depth of field: the CoC is monotonic in depth, so the nearest and farthest depths bound it.
    let (near_m, far_m) = frame.depth_m.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), &d| (lo.min(d), hi.max(d)));
    let coc_px = |d_m: f32| {
        let c = camera.lens.coc_mm(d_m as f64 * 1000.0) / pitch_mm;
        c.clamp(-camera.max_coc_px, camera.max_coc_px)
    };
    let mut coc_range_px = if frame.depth_m.is_empty() { (0.0, 0.0) } else { (coc_px(near_m), coc_px(far_m)) };
    // With field curvature the CoC also depends on the image height: evaluate every pixel with
    // the CoC pass's CPU twin.
    let coc_table = crate::passes::coc::table_data(camera.field_curvature.as_ref());
    let coc_params = CocParams::new(
        &camera.lens,
        pitch_mm,
        camera.max_coc_px,
        w,
        h,
        frame.centre_px,
        camera.field_curvature.as_ref(),
    );
    if camera.field_curvature.is_some() {
        coc_range_px = crate::passes::coc::coc_cpu(&frame.depth_m, &coc_params, &coc_table)
            .iter()
            .fold((f64::MAX, f64::MIN), |(lo, hi), &c| (lo.min(c as f64), hi.max(c as f64)));
    }
    // Longitudinal colour shifts the red and blue CoC by constants: an in-focus point gets
    // red and blue disks of those diameters. Visible when one exceeds a pixel.
    let lca_offsets_px = camera.longitudinal_color_coc_px(pitch_mm);
    let lca_visible = lca_offsets_px.is_some_and(|[r, b]| r.abs().max(b.abs()) > VISIBLE_COC_PX);
    if let (Some([r, b]), true) = (lca_offsets_px, lca_visible) {
        let clamp = |c: f64| c.clamp(-camera.max_coc_px, camera.max_coc_px);
        coc_range_px = (clamp(coc_range_px.0 + r.min(b).min(0.0)), clamp(coc_range_px.1 + r.max(b).max(0.0)));
    }
    let max_abs_coc_px = coc_range_px.0.abs().max(coc_range_px.1.abs());
    let dof = max_abs_coc_px > VISIBLE_COC_PX;
    let coc_why = format!(
        "CoC from {:.2} px (nearest, {:.3} m) to {:.2} px (farthest, {:.3e} m) at f/{} focused at {} m",
        coc_range_px.0,
        near_m,
        coc_range_px.1,
        far_m,
        camera.lens.f_number,
        camera.lens.focus_distance_mm / 1000.0
    );
    let aperture_text = if camera.aperture_mask.is_some() {
        "the user's aperture image".to_string()
    } else if camera.aperture.blades >= 3 {
        format!("{}-bladed aperture", camera.aperture.blades)
    } else {
        "circular aperture".into()
    };
    // What of the aperture depends on the pixel pitch, set after the bokeh pass's constants:
    // traced spherical aberration, the rim's focus shift seen as a CoC (src/optics/spherical.rs),
    // and a cat's eye given at an image height, growing linearly from the centre (per pixel).
    let with_pitch = |aperture: &mut crate::passes::aperture::ApertureConstants| {
        if let Some(lsa_mm) = camera.aperture.lsa_rim_mm {
            let n = camera.lens.effective_f_number() * camera.lens.pupil_magnification;
            aperture.sa_lsa_coc_px = (-lsa_mm / (n * pitch_mm)) as f32;
        }
        if let Some(h_mm) = camera.aperture.cats_eye_at_mm {
            aperture.cats_eye_per_px = (camera.aperture.cats_eye.clamp(0.0, 1.0) * pitch_mm / h_mm) as f32;
        }
    };
    let (mut coc, mut gather, mut tiled, mut diffraction) = (None, None, None, None);
    if dof {
        steps.push(Step { pass: crate::passes::coc::NAME, run: true, why: coc_why });
        coc = Some(coc_params);
        match camera.bokeh {
            BokehMode::Reference => {
                let mut g =
                    GatherParams::new(w, h, max_abs_coc_px, &camera.aperture, camera.max_coc_px, frame.centre_px);
                with_pitch(&mut g.aperture);
                steps.push(Step {
                    pass: crate::passes::bokeh_gather::NAME,
                    run: true,
                    why: format!(
                        "--bokeh reference: largest CoC {max_abs_coc_px:.1} px > {VISIBLE_COC_PX} px, exact gather of radius {} px everywhere, {aperture_text}",
                        g.radius_px
                    ),
                });
                gather = Some(g);
            }
            BokehMode::Diffraction => {
                // The focus processor maps depth to its tables itself: no CoC image.
                coc = None;
                if let Some(step) = steps.last_mut() {
                    step.run = false;
                    step.why = format!("{}; not needed by the focus processor", step.why);
                }
                let settings = crate::optics::focus_processor::PsfTableSettings {
                    subpixel: 1,
                    max_radius_px: (0.5 * camera.max_coc_px).ceil().max(1.0) as u32 + 4,
                    ..Default::default()
                };
                let tables = crate::optics::focus_processor::build_tables(
                    &camera.lens,
                    pitch_mm,
                    near_m.max(1e-6) as f64,
                    far_m as f64,
                    &settings,
                );
                let params = crate::passes::diffraction::DiffractionParams::new(&tables, w, h);
                steps.push(Step {
                    pass: crate::passes::diffraction::NAME,
                    run: true,
                    why: format!(
                        "--bokeh diffraction: Potmesil & Chakravarty focus processor, {} depth tables of radius {} px at 650/550/450 nm, gathered over the whole frame",
                        tables.levels(),
                        tables.radius_px
                    ),
                });
                diffraction = Some((std::sync::Arc::new(tables), params));
            }
            BokehMode::Tiled => {
                let mut t =
                    TiledDofParams::new(w, h, max_abs_coc_px, &camera.aperture, camera.max_coc_px, frame.centre_px);
                with_pitch(&mut t.aperture);
                steps.push(Step {
                    pass: BOKEH_TILED,
                    run: true,
                    why: format!(
                        "largest CoC {max_abs_coc_px:.1} px > {VISIBLE_COC_PX} px: {}x{} tiles of {} px; in-focus tiles copied, CoC radius <= {} px gathered exactly, larger at half resolution ({} rings) with highlight sprites; {aperture_text}",
                        t.tiles()[0],
                        t.tiles()[1],
                        crate::passes::TILE_SIZE,
                        t.small_radius_px,
                        t.rings
                    ),
                });
                tiled = Some(t);
            }
        }
    } else {
        let why = format!("{coc_why}: every CoC is at most {VISIBLE_COC_PX} px, depth of field is invisible");
        steps.push(Step { pass: crate::passes::coc::NAME, run: false, why });
        let bokeh = if camera.bokeh == BokehMode::Tiled { BOKEH_TILED } else { crate::passes::bokeh_gather::NAME };
        steps.push(Step { pass: bokeh, run: false, why: "no pixel is defocused by more than a pixel".into() });
    }

    let mut longitudinal_color_px = None;
    let lca_step = |run: bool, why: String| Step { pass: crate::passes::longitudinal_color::NAME, run, why };
    match (camera.longitudinal_color_mm, lca_offsets_px) {
        (Some([red_mm, blue_mm]), Some([r, b])) => {
            let shifts = format!(
                "red focuses {red_mm:+.4} mm and blue {blue_mm:+.4} mm from green: CoC offsets {r:+.2} / {b:+.2} px"
            );
            if !lca_visible {
                steps.push(lca_step(false, format!("{shifts}, at most {VISIBLE_COC_PX} px: invisible")));
            } else if camera.bokeh == BokehMode::Diffraction {
                steps.push(lca_step(false, format!("{shifts}; the focus processor does not model it")));
            } else if dof {
                steps.push(lca_step(true, format!("{shifts}: the depth of field runs once per channel (3x its cost)")));
                longitudinal_color_px = Some([r as f32, b as f32]);
            }
        }
        _ => steps.push(lca_step(false, "the lens file has no longitudinal_color".into())),
    }

    steps.push(match &frame.velocity_px {
        None => Step { pass: "motion_blur", run: false, why: "no velocity pass".into() },
        Some(v) => {
            let max_px = v.chunks_exact(2).map(|m| (m[0] * m[0] + m[1] * m[1]).sqrt()).fold(0.0f32, f32::max);
            Step {
                pass: "motion_blur",
                run: false,
                why: format!("velocity up to {max_px:.1} px/frame is read, but this version has no motion-blur pass"),
            }
        }
    });

    let distortion = match &camera.distortion {
        Some(tables) if !tables.is_zero() => {
            steps.push(Step {
                pass: crate::passes::distortion::NAME,
                run: true,
                why: format!(
                    "the lens's tables: distortion up to {:.2}%, lateral colour up to {:.3}% (red) and {:.3}% (blue)",
                    tables.green_percent.max_abs(),
                    tables.red_extra_percent.max_abs(),
                    tables.blue_extra_percent.max_abs()
                ),
            });
            let params = crate::passes::distortion::DistortionParams {
                size: [w as i32, h as i32],
                centre_px: [frame.centre_px[0] as f32, frame.centre_px[1] as f32],
                pixel_pitch_mm: pitch_mm as f32,
                entries: tables.green_percent.image_height_mm.len() as i32,
            };
            Some((params, crate::passes::distortion::table_data(tables)))
        }
        _ => {
            let why = if camera.distortion.is_some() {
                "the lens's tables are all zero"
            } else {
                "the lens file has no distortion or lateral-colour tables"
            };
            steps.push(Step { pass: crate::passes::distortion::NAME, run: false, why: why.into() });
            None
        }
    };

    // The farthest a pixel centre lies from the optical centre, on the film.
    let corner_mm = {
        let (cx, cy) = (frame.centre_px[0], frame.centre_px[1]);
        let dx = cx.max(w as f64 - cx);
        let dy = cy.max(h as f64 - cy);
        (dx * dx + dy * dy).sqrt() * pitch_mm
    };
    let astigmatism = match &camera.astigmatism {
        Some((t, s)) if !(t.is_zero() && s.is_zero()) => {
            steps.push(Step {
                pass: crate::passes::astigmatism::NAME,
                run: true,
                why: format!(
                    "the lens's tables: tangential blur up to {:.1} px, sagittal up to {:.1} px in the frame",
                    t.max_abs_within(corner_mm) / pitch_mm,
                    s.max_abs_within(corner_mm) / pitch_mm
                ),
            });
            let params = crate::passes::astigmatism::AstigmatismParams {
                size: [w as i32, h as i32],
                centre_px: [frame.centre_px[0] as f32, frame.centre_px[1] as f32],
                pixel_pitch_mm: pitch_mm as f32,
                entries: t.image_height_mm.len() as i32,
                direction: 0,
            };
            Some((params, crate::passes::astigmatism::table_data(t, s)))
        }
        _ => {
            steps.push(Step {
                pass: crate::passes::astigmatism::NAME,
                run: false,
                why: "the lens has no (non-zero) tangential or sagittal blur tables".into(),
            });
            None
        }
    };

    let coma = match &camera.coma {
        // A comet shorter than a pixel is invisible (its light moves by a third of that).
        Some(t) if t.max_abs_within(corner_mm) / pitch_mm >= 1.0 => {
            steps.push(Step {
                pass: crate::passes::coma::NAME,
                run: true,
                why: format!(
                    "the lens's coma table: comets up to {:.1} px long in the frame at f/{}",
                    t.max_abs_within(corner_mm) / pitch_mm,
                    camera.lens.f_number
                ),
            });
            let params = crate::passes::coma::ComaParams::new([w, h], frame.centre_px, pitch_mm, t);
            Some((params, crate::passes::coma::table_data(t)))
        }
        Some(t) => {
            steps.push(Step {
                pass: crate::passes::coma::NAME,
                run: false,
                why: format!(
                    "the lens's comets are at most {:.3} px long in the frame (< 1 px): invisible",
                    t.max_abs_within(corner_mm) / pitch_mm
                ),
            });
            None
        }
        None => {
            steps.push(Step {
                pass: crate::passes::coma::NAME,
                run: false,
                why: "the lens file has no coma table".into(),
            });
            None
        }
    };

    let vignette_params = VignetteParams {
        size: [w as i32, h as i32],
        centre_px: [frame.centre_px[0] as f32, frame.centre_px[1] as f32],
        pixel_pitch_mm: pitch_mm as f32,
        image_distance_mm: camera.lens.image_distance_mm() as f32,
        entries: camera.relative_illumination.as_ref().map_or(0, |t| t.image_height_mm.len() as i32),
    };
    let vignette_table = crate::passes::vignette::table_data(camera.relative_illumination.as_ref());
    let falloff_name = if camera.relative_illumination.is_some() {
        "the lens's relative illumination"
    } else {
        "cos^4 natural vignetting"
    };
    let corner = vignette_params.corner_falloff(&vignette_table) as f64;
    let vignette = if !camera.vignetting {
        steps.push(Step {
            pass: crate::passes::vignette::NAME,
            run: false,
            why: "turned off (--no-vignetting)".into(),
        });
        None
    } else if 1.0 - corner <= VISIBLE_FALLOFF {
        steps.push(Step {
            pass: crate::passes::vignette::NAME,
            run: false,
            why: format!("{falloff_name} at the corners is {corner:.6}: invisible"),
        });
        None
    } else {
        steps.push(Step {
            pass: crate::passes::vignette::NAME,
            run: true,
            why: format!("{falloff_name}: {:.1}% of the centre's light at the farthest corner", corner * 100.0),
        });
        Some(vignette_params)
    };

    let gain = camera.exposure_gain();
    let (curve, film_table) = match &camera.film {
        FilmMode::Curve(c) => (Some(*c), None),
        FilmMode::Table(t) => (Some(crate::optics::FilmCurve::default_filmic()), Some(t.clone())),
        FilmMode::Linear => (None, None),
    };
    let noise_sigma = camera.noise_sigma();
    let film = if curve.is_none() && gain == 1.0 && noise_sigma == 0.0 {
        steps.push(Step {
            pass: crate::passes::film::NAME,
            run: false,
            why: "linear film with exposure off and no grain: the sensor value is the scene value".into(),
        });
        None
    } else {
        let exposure = if camera.exposure {
            format!(
                "exposure gain {gain:.4} (ISO {}, {} s, f/{}, N' {:.2})",
                camera.iso,
                camera.shutter_s,
                camera.lens.f_number,
                camera.lens.effective_f_number()
            )
        } else {
            "exposure off".into()
        };
        let response = match (&curve, &film_table) {
            (_, Some(t)) => format!("characteristic curve from a table of {} entries", t.log10_sensor_value.len()),
            (Some(_), None) => "characteristic curve".into(),
            (None, None) => "linear (scene-referred)".into(),
        };
        let grain = if noise_sigma > 0.0 {
            format!(", sensor noise sigma {noise_sigma:.4} at ISO {} (seed {})", camera.iso, camera.seed)
        } else {
            String::new()
        };
        steps.push(Step { pass: crate::passes::film::NAME, run: true, why: format!("{exposure}, {response}{grain}") });
        let mut params = FilmParams::new(w, h, gain, curve.as_ref());
        if let Some(t) = &film_table {
            params = params.with_table(t);
        }
        params.noise_sigma = noise_sigma as f32;
        params.seed = camera.seed;
        Some(params)
    };

    let aperture_mask = crate::model::aperture::ApertureMask::buffer_data(camera.aperture_mask.as_ref());
    Plan {
        steps,
        coc,
        gather,
        tiled,
        diffraction,
        distortion,
        astigmatism,
        longitudinal_color_px,
        coma,
        coc_table,
        vignette,
        vignette_table,
        film,
        film_table: crate::passes::film::table_data(film_table.as_ref().map(|t| t.as_ref())),
        aperture_mask,
        coc_range_px,
    }
}
