//! Runs a plan on the GPU: creates only the pipelines the plan needs, uploads the frame,
//! records the passes in order, reads the result back.

use crate::gpu::{Gpu, GpuResult, Profile, Recorder};
use crate::model::frame::Frame;
use crate::passes::tiled_dof::TiledDof;
use crate::passes::{bokeh_gather::BokehGatherPass, coc::CocPass, film::FilmPass, vignette::VignettePass};
use crate::pipeline::planner::Plan;
use ash::vk;

/// The pipelines of one plan.
pub struct Renderer {
    gpu: Gpu,
    coc: Option<CocPass>,
    gather: Option<BokehGatherPass>,
    tiled: Option<TiledDof>,
    diffraction: Option<crate::passes::diffraction::DiffractionPass>,
    distortion: Option<crate::passes::distortion::DistortionPass>,
    astigmatism: Option<crate::passes::astigmatism::AstigmatismPass>,
    coma: Option<crate::passes::coma::ComaPass>,
    longitudinal_color: Option<crate::passes::longitudinal_color::LongitudinalColorPass>,
    vignette: Option<VignettePass>,
    film: Option<FilmPass>,
}

/// What a render returns.
pub struct Rendered {
    /// RGBA, row-major.
    pub rgba: Vec<f32>,
    /// Signed CoC per pixel when the CoC pass ran and `keep_coc` was asked.
    pub coc_px: Option<Vec<f32>>,
    pub profile: Profile,
}

impl Renderer {
    pub fn new(gpu: &Gpu, plan: &Plan) -> GpuResult<Renderer> {
        Ok(Renderer {
            gpu: gpu.clone(),
            coc: plan.coc.as_ref().map(|_| CocPass::new(gpu)).transpose()?,
            gather: plan.gather.as_ref().map(|_| BokehGatherPass::new(gpu)).transpose()?,
            tiled: plan.tiled.as_ref().map(|_| TiledDof::new(gpu)).transpose()?,
            diffraction: plan
                .diffraction
                .as_ref()
                .map(|_| crate::passes::diffraction::DiffractionPass::new(gpu))
                .transpose()?,
            distortion: plan
                .distortion
                .as_ref()
                .map(|_| crate::passes::distortion::DistortionPass::new(gpu))
                .transpose()?,
            astigmatism: plan
                .astigmatism
                .as_ref()
                .map(|_| crate::passes::astigmatism::AstigmatismPass::new(gpu))
                .transpose()?,
            coma: plan.coma.as_ref().map(|_| crate::passes::coma::ComaPass::new(gpu)).transpose()?,
            longitudinal_color: plan
                .longitudinal_color_px
                .map(|_| crate::passes::longitudinal_color::LongitudinalColorPass::new(gpu))
                .transpose()?,
            vignette: plan.vignette.as_ref().map(|_| VignettePass::new(gpu)).transpose()?,
            film: plan.film.as_ref().map(|_| FilmPass::new(gpu)).transpose()?,
        })
    }

    pub fn render(&self, frame: &Frame, plan: &Plan, keep_coc: bool) -> GpuResult<Rendered> {
        let dof = self.gather.is_some() || self.tiled.is_some() || self.diffraction.is_some();
        if !dof
            && self.coc.is_none()
            && self.distortion.is_none()
            && self.astigmatism.is_none()
            && self.coma.is_none()
            && self.vignette.is_none()
            && self.film.is_none()
        {
            // Nothing to simulate: the pinhole image is the camera image; the GPU is not touched.
            let profile = Profile { device: self.gpu.info().to_string(), ..Default::default() };
            return Ok(Rendered { rgba: frame.color.clone(), coc_px: None, profile });
        }
        let (w, h) = (frame.width, frame.height);
        let gpu = &self.gpu;
        let mut rec = Recorder::new(gpu, "realcam frame")?;
        let rgba = vk::Format::R32G32B32A32_SFLOAT;
        let color_in = gpu.create_image("color (input)", w, h, rgba)?;
        rec.begin_pass("upload");
        let depth = if plan.coc.is_some() || plan.diffraction.is_some() {
            let depth = gpu.create_image("depth (m)", w, h, vk::Format::R32_SFLOAT)?;
            rec.upload_images(&[(&color_in, &frame.color), (&depth, &frame.depth_m)])?;
            Some(depth)
        } else {
            rec.upload_images(&[(&color_in, &frame.color)])?;
            None
        };
        rec.end_pass();

        // Every pass writes its own image (no aliasing, so no write-after-read hazards between
        // passes); `current` is the latest color.
        let image = |name: &str, format, needed: bool| needed.then(|| gpu.create_image(name, w, h, format)).transpose();
        let coc_image = image("coc (px)", vk::Format::R32_SFLOAT, self.coc.is_some())?;
        let dof_out = image("color (depth of field)", rgba, dof)?;
        let distortion_out = image("color (distortion)", rgba, self.distortion.is_some())?;
        let astigmatism_between = image("color (tangential blur)", rgba, self.astigmatism.is_some())?;
        let astigmatism_out = image("color (astigmatism)", rgba, self.astigmatism.is_some())?;
        let coma_out = image("color (coma)", rgba, self.coma.is_some())?;
        let vignette_out = image("color (vignetting)", rgba, self.vignette.is_some())?;
        let film_out = image("color (film)", rgba, self.film.is_some())?;
        let mut current = &color_in;

        let aperture_mask = match (&self.gather, &self.tiled) {
            (None, None) => None,
            _ => Some(rec.upload_buffer("aperture image", &plan.aperture_mask)?),
        };
        let coc_table = match &self.coc {
            Some(_) => Some(rec.upload_buffer("field curvature", &plan.coc_table)?),
            None => None,
        };
        // Longitudinal colour: the CoC pass and the depth of field once per channel, each with
        // its channel's CoC offset, into images of their own, then joined into dof_out (green's
        // run uses coc_image, which --keep-coc reads back). Otherwise one run into dof_out.
        let per_channel = match (&self.longitudinal_color, plan.longitudinal_color_px) {
            (Some(_), Some([red_px, blue_px])) => {
                let mut per_channel = Vec::new();
                for (channel, offset_px) in [("red", red_px), ("green", 0.0), ("blue", blue_px)] {
                    let coc = if channel == "green" {
                        None
                    } else {
                        Some(gpu.create_image(&format!("coc (px, {channel})"), w, h, vk::Format::R32_SFLOAT)?)
                    };
                    let out = gpu.create_image(&format!("color (depth of field, {channel})"), w, h, rgba)?;
                    per_channel.push((offset_px, coc, out));
                }
                per_channel
            }
            _ => Vec::new(),
        };
        let runs: Vec<(f32, Option<&crate::gpu::GpuImage>, Option<&crate::gpu::GpuImage>)> = if per_channel.is_empty() {
            vec![(0.0, coc_image.as_ref(), dof_out.as_ref())]
        } else {
            per_channel
                .iter()
                .map(|(offset_px, coc, out)| (*offset_px, coc.as_ref().or(coc_image.as_ref()), Some(out)))
                .collect()
        };
        let mut _tiled_frames = Vec::new();
        for (offset_px, coc, out) in runs {
            if let (Some(pass), Some(params), Some(depth), Some(coc), Some(table)) =
                (&self.coc, &plan.coc, &depth, coc, &coc_table)
            {
                let params = crate::passes::coc::CocParams { coc_offset_px: offset_px, ..*params };
                pass.record(&mut rec, depth, coc, table, &params)?;
            }
            if let (Some(pass), Some(params), Some(coc), Some(out), Some(mask)) =
                (&self.gather, &plan.gather, coc, out, &aperture_mask)
            {
                pass.record(&mut rec, current, coc, out, mask, params)?;
            }
            if let (Some(tiled), Some(params), Some(coc), Some(out), Some(mask)) =
                (&self.tiled, &plan.tiled, coc, out, &aperture_mask)
            {
                _tiled_frames.push(tiled.record(&mut rec, current, coc, out, mask, params)?);
            }
        }
        if let (Some(pass), [(_, _, red), (_, _, green), (_, _, blue)], Some(out)) =
            (&self.longitudinal_color, &per_channel[..], &dof_out)
        {
            pass.record(&mut rec, [red, green, blue], out)?;
        }
        if let (true, Some(out)) = (self.gather.is_some() || self.tiled.is_some(), &dof_out) {
            current = out;
        }
        let mut _tables = None;
        if let (Some(pass), Some((tables, params)), Some(depth), Some(out)) =
            (&self.diffraction, &plan.diffraction, &depth, &dof_out)
        {
            let table = rec.upload_buffer("psf tables", &tables.data)?;
            pass.record(&mut rec, current, depth, &table, out, params)?;
            current = out;
            _tables = Some(table);
        }
        let mut _distortion_tables = None;
        if let (Some(pass), Some((params, data)), Some(out)) = (&self.distortion, &plan.distortion, &distortion_out) {
            let tables = rec.upload_buffer("distortion tables", data)?;
            pass.record(&mut rec, current, out, &tables, params)?;
            current = out;
            _distortion_tables = Some(tables);
        }
        let mut _astigmatism_tables = None;
        if let (Some(pass), Some((params, data)), Some(between), Some(out)) =
            (&self.astigmatism, &plan.astigmatism, &astigmatism_between, &astigmatism_out)
        {
            let tables = rec.upload_buffer("astigmatism tables", data)?;
            pass.record(&mut rec, current, between, out, &tables, params)?;
            current = out;
            _astigmatism_tables = Some(tables);
        }
        let mut _coma_table = None;
        if let (Some(pass), Some((params, data)), Some(out)) = (&self.coma, &plan.coma, &coma_out) {
            let table = rec.upload_buffer("coma table", data)?;
            pass.record(&mut rec, current, out, &table, params)?;
            current = out;
            _coma_table = Some(table);
        }
        let mut _vignette_table = None;
        if let (Some(pass), Some(params), Some(out)) = (&self.vignette, &plan.vignette, &vignette_out) {
            let table = rec.upload_buffer("relative illumination", &plan.vignette_table)?;
            pass.record(&mut rec, current, out, &table, params)?;
            _vignette_table = Some(table);
            current = out;
        }
        let mut _film_table = None;
        if let (Some(pass), Some(params), Some(out)) = (&self.film, &plan.film, &film_out) {
            let table = rec.upload_buffer("film table", &plan.film_table)?;
            pass.record(&mut rec, current, out, &table, params)?;
            _film_table = Some(table);
            current = out;
        }

        rec.begin_pass("download");
        let out_id = rec.download_image(current, 4)?;
        let coc_id = match (&coc_image, keep_coc) {
            (Some(coc), true) => Some(rec.download_image(coc, 1)?),
            _ => None,
        };
        rec.end_pass();
        let (profile, mut data) = rec.submit()?;
        let coc_px = coc_id.map(|id| std::mem::take(&mut data[id.index()]));
        let rgba = std::mem::take(&mut data[out_id.index()]);
        Ok(Rendered { rgba, coc_px, profile })
    }
}
