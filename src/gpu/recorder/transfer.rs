//! Uploads into images and buffers, copies between images, and read-backs of images after the
//! submission.

use super::*;

impl Recorder {
    /// Copy all of `src` into `dst` (same size and format, both in layout GENERAL): a transfer
    /// read and write, ordered and made visible by the caller's barriers before and after.
    pub fn copy_image(&mut self, src: &GpuImage, dst: &GpuImage) {
        let layers = vk::ImageSubresourceLayers::default().aspect_mask(vk::ImageAspectFlags::COLOR).layer_count(1);
        let region = vk::ImageCopy::default().src_subresource(layers).dst_subresource(layers).extent(vk::Extent3D {
            width: src.width.min(dst.width),
            height: src.height.min(dst.height),
            depth: 1,
        });
        unsafe {
            self.gpu.device().cmd_copy_image(
                self.cb,
                src.image,
                vk::ImageLayout::GENERAL,
                dst.image,
                vk::ImageLayout::GENERAL,
                &[region],
            )
        };
    }

    /// Upload f32 pixels into images. Afterwards each image is in layout GENERAL and its
    /// contents are visible to compute-shader reads: the barriers below are the hand-off from
    /// the host's writes or the copy to whichever pass reads the image first.
    pub fn upload_images(&mut self, uploads: &[(&GpuImage, &[f32])]) -> GpuResult<()> {
        // An image in host memory that this recording has not used yet (so no work before the
        // upload touches it) is written by the host now; the others go through a staging
        // buffer and a copy.
        let mut direct = Vec::new();
        let mut staged_uploads = Vec::new();
        for &(image, data) in uploads {
            let unused = !self.layouts.iter().any(|(i, _)| *i == image.image);
            // SAFETY: an image this recording has not used is new or from the idle pool (the
            // rule of src/gpu/pool.rs): no work that uses it is pending.
            match unused && image.host_writable() && unsafe { image.write_host(data) } {
                true => direct.push(image),
                false => staged_uploads.push((image, data)),
            }
        }
        let uploads = staged_uploads;
        // Host writes -> compute reads (and writes), with the move to GENERAL: the submission
        // makes the host's writes before it visible to the device; this orders the layout move
        // after them and the passes after the move. PREINITIALIZED and GENERAL keep the texels.
        let host_written: Vec<_> = direct
            .iter()
            .map(|image| {
                vk::ImageMemoryBarrier2::default()
                    .src_stage_mask(vk::PipelineStageFlags2::HOST)
                    .src_access_mask(vk::AccessFlags2::HOST_WRITE)
                    .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
                    .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE)
                    .old_layout(image.layout())
                    .new_layout(vk::ImageLayout::GENERAL)
                    .image(image.image)
                    .subresource_range(color_range())
            })
            .collect();
        if !host_written.is_empty() {
            self.image_barriers(&host_written);
        }
        if uploads.is_empty() {
            return Ok(());
        }
        let mut staged = Vec::new();
        for (image, data) in &uploads {
            // Straight from the frame's floats into the mapped staging memory: no copy of a
            // whole frame on the way (a 1280x720 colour is 15 MB, each fresh page a fault).
            let bytes: &[u8] = bytemuck::cast_slice(data);
            let mut buffer = self.gpu.create_buffer(
                &format!("{} upload", image.name),
                bytes.len() as u64,
                vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::CpuToGpu,
            )?;
            buffer.write_bytes(bytes);
            staged.push(buffer);
        }
        // UNDEFINED -> TRANSFER_DST: the old contents are discarded; nothing earlier touched
        // these images, so no source stage is needed.
        let to_transfer: Vec<_> = uploads
            .iter()
            .map(|(image, _)| {
                vk::ImageMemoryBarrier2::default()
                    .src_stage_mask(vk::PipelineStageFlags2::NONE)
                    .src_access_mask(vk::AccessFlags2::NONE)
                    .dst_stage_mask(vk::PipelineStageFlags2::COPY)
                    .dst_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
                    .old_layout(vk::ImageLayout::UNDEFINED)
                    .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
                    .image(image.image)
                    .subresource_range(color_range())
            })
            .collect();
        self.image_barriers(&to_transfer);
        for ((image, _), buffer) in uploads.iter().zip(&staged) {
            let region = buffer_image_region(image);
            unsafe {
                self.gpu.device().cmd_copy_buffer_to_image(
                    self.cb,
                    buffer.buffer,
                    image.image,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &[region],
                )
            };
        }
        // Copy writes -> compute reads (and writes, for passes that update in place), with the
        // move to GENERAL, the one layout every pass uses for storage images.
        let to_general: Vec<_> = uploads
            .iter()
            .map(|(image, _)| {
                vk::ImageMemoryBarrier2::default()
                    .src_stage_mask(vk::PipelineStageFlags2::COPY)
                    .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
                    .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
                    .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE)
                    .old_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
                    .new_layout(vk::ImageLayout::GENERAL)
                    .image(image.image)
                    .subresource_range(color_range())
            })
            .collect();
        self.image_barriers(&to_general);
        self.staging.extend(staged);
        Ok(())
    }

    /// A device-local storage buffer holding `data` (lookup tables and the like). The copy is
    /// made visible to compute-shader reads by the barrier recorded here.
    pub fn upload_buffer(&mut self, name: &str, data: &[f32]) -> GpuResult<Arc<GpuBuffer>> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let size = bytes.len().max(4) as u64;
        let mut staging = self.gpu.create_buffer(
            &format!("{name} upload"),
            size,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        staging.write_bytes(bytes);
        let buffer = self.gpu.create_buffer(
            name,
            size,
            // A copy source too: twin checks read every buffer back.
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        unsafe {
            self.gpu.device().cmd_copy_buffer(
                self.cb,
                staging.buffer,
                buffer.buffer,
                &[vk::BufferCopy { src_offset: 0, dst_offset: 0, size }],
            )
        };
        // Copy writes -> compute reads (and writes: a step may update what was uploaded).
        self.buffer_barriers(&[vk::BufferMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COPY)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE)
            .buffer(buffer.buffer)
            .offset(0)
            .size(vk::WHOLE_SIZE)]);
        self.staging.push(staging);
        let buffer = Arc::new(buffer);
        self.buffers.push(buffer.clone());
        Ok(buffer)
    }

    /// Read an image back after the submission. The image must have been last written by a
    /// compute shader (every pass's output is).
    pub fn download_image(&mut self, image: &GpuImage, channels: u32) -> GpuResult<Download> {
        self.download_image_into(image, channels, Vec::new())
    }

    /// [`Recorder::download_image`] into `memory`'s allocation where it can (an image in host
    /// memory): a buffer the caller no longer needs, whose pages are already the process's.
    pub fn download_image_into(&mut self, image: &GpuImage, channels: u32, memory: Vec<f32>) -> GpuResult<Download> {
        // An image in host memory is read where it is, after the fence: no copy on the device.
        let own = self.images.iter().find(|i| i.image == image.image && i.in_host_memory()).cloned();
        if let Some(own) = own {
            // Compute writes -> host reads after the fence; it stays in GENERAL, where the host
            // may read it.
            self.image_barriers(&[vk::ImageMemoryBarrier2::default()
                .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
                .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
                .dst_stage_mask(vk::PipelineStageFlags2::HOST)
                .dst_access_mask(vk::AccessFlags2::HOST_READ)
                .old_layout(vk::ImageLayout::GENERAL)
                .new_layout(vk::ImageLayout::GENERAL)
                .image(image.image)
                .subresource_range(color_range())]);
            self.downloads.push(Readback::Image(own, channels, memory));
            return Ok(Download(self.downloads.len() - 1));
        }
        let size = image.width as u64 * image.height as u64 * channels as u64 * 4;
        let buffer = self.gpu.create_buffer(
            &format!("{} readback", image.name),
            size,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        // Compute writes -> copy reads, moving to the copy's optimal layout. Read-back is the
        // last use of an image in a recording, so nothing moves it back to GENERAL.
        self.image_barriers(&[vk::ImageMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::COPY)
            .dst_access_mask(vk::AccessFlags2::TRANSFER_READ)
            .old_layout(vk::ImageLayout::GENERAL)
            .new_layout(vk::ImageLayout::TRANSFER_SRC_OPTIMAL)
            .image(image.image)
            .subresource_range(color_range())]);
        let region = buffer_image_region(image);
        unsafe {
            self.gpu.device().cmd_copy_image_to_buffer(
                self.cb,
                image.image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                buffer.buffer,
                &[region],
            )
        };
        // Copy writes -> host reads after the fence.
        self.buffer_barriers(&[vk::BufferMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COPY)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::HOST)
            .dst_access_mask(vk::AccessFlags2::HOST_READ)
            .buffer(buffer.buffer)
            .offset(0)
            .size(vk::WHOLE_SIZE)]);
        self.downloads.push(Readback::Buffer(buffer));
        Ok(Download(self.downloads.len() - 1))
    }
}

pub(super) fn buffer_image_region(image: &GpuImage) -> vk::BufferImageCopy {
    vk::BufferImageCopy {
        buffer_offset: 0,
        buffer_row_length: 0,
        buffer_image_height: 0,
        image_subresource: vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        },
        image_offset: vk::Offset3D { x: 0, y: 0, z: 0 },
        image_extent: vk::Extent3D { width: image.width, height: image.height, depth: 1 },
    }
}
