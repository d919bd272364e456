//! One command buffer, recorded pass by pass and submitted once. Each pass is bracketed by a
//! debug label and two timestamps; descriptor sets come from a pool owned by the recording, and
//! so do the images and buffers created during it, which live until the submission completed.
//! Barriers are not inferred here: every pass writes its own (see `src/passes/`).
//!
//! Every dispatch's bindings are checked against the shader's declaration. A recording made with
//! [`Recorder::with_twin_checks`] also runs every dispatch against the shader's CPU twin: it
//! submits before and after each dispatch, reads the bound resources back, runs the twin on the
//! copy from before and compares (see [`TwinCheck`]); for tests.

use super::kernel::{compare_with_twin, Binding, HostData, HostImage, TwinFn};
use super::profiler::{PassTiming, Profile};
use super::reflect::BindingKind;
use super::resources::color_range;
use super::{ComputePipeline, Gpu, GpuBuffer, GpuError, GpuImage, GpuResult, VkContext};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::ffi::CString;
use std::sync::Arc;

const MAX_TIMED_SPANS: u32 = 128;

/// A resource bound to one binding of a pass's descriptor set.
pub enum Bind<'a> {
    /// A storage image in layout GENERAL.
    Image(&'a GpuImage),
    /// A storage or uniform buffer, whole.
    Buffer(&'a GpuBuffer),
}

/// One dispatch run against its CPU twin ([`Recorder::with_twin_checks`]).
#[derive(Clone, Debug)]
pub struct TwinCheck {
    /// The pass (span) the dispatch was recorded in.
    pub pass: String,
    pub shader: &'static str,
    /// The workgroups it ran (an indirect dispatch's as read from its arguments; 0 in x: none).
    pub groups: [u32; 3],
    /// `Err` names the first binding and texel or word where GPU and twin differ.
    pub result: Result<(), String>,
}

/// Recording of one frame's work.
pub struct Recorder {
    gpu: Gpu,
    command_pool: vk::CommandPool,
    cb: vk::CommandBuffer,
    descriptor_pool: vk::DescriptorPool,
    query_pool: Option<vk::QueryPool>,
    spans: Vec<String>,
    open_span: Option<usize>,
    staging: Vec<GpuBuffer>,
    downloads: Vec<Readback>,
    /// The layouts this recording's barriers move images to, in order: given to the images
    /// once the submission completed (an upload into an image in host memory needs its layout).
    layouts: Vec<(vk::Image, vk::ImageLayout)>,
    /// Images and buffers the passes created: alive until the recording is dropped, after the
    /// submission completed.
    images: Vec<Arc<GpuImage>>,
    buffers: Vec<Arc<GpuBuffer>>,
    /// `Some` when every dispatch is checked against its twin.
    twin_checks: Option<Vec<TwinCheck>>,
}

/// Handle to an image read back by [`Recorder::download_image`].
#[derive(Clone, Copy, Debug)]
pub struct Download(usize);

/// Where a read-back's texels are after the submission.
enum Readback {
    /// Copied into a host-visible buffer.
    Buffer(GpuBuffer),
    /// In the image's own mapped memory (an image in host memory), `channels` f32 per texel;
    /// read into the vector's allocation.
    Image(Arc<GpuImage>, u32, Vec<f32>),
}

impl Recorder {
    pub fn new(gpu: &Gpu, label: &str) -> GpuResult<Recorder> {
        Self::create(gpu, label, false)
    }

    /// A recording that runs every dispatch against the shader's CPU twin (slow: it submits
    /// around each dispatch; no timestamps). The results come back from [`Recorder::submit`].
    pub fn with_twin_checks(gpu: &Gpu, label: &str) -> GpuResult<Recorder> {
        Self::create(gpu, label, true)
    }

    fn create(gpu: &Gpu, label: &str, twin_checks: bool) -> GpuResult<Recorder> {
        let device = gpu.device();
        unsafe {
            let command_pool = device
                .create_command_pool(
                    &vk::CommandPoolCreateInfo::default()
                        .queue_family_index(gpu.shared.queue_family)
                        .flags(vk::CommandPoolCreateFlags::TRANSIENT),
                    None,
                )
                .vk("vkCreateCommandPool")?;
            let cb = device
                .allocate_command_buffers(
                    &vk::CommandBufferAllocateInfo::default()
                        .command_pool(command_pool)
                        .level(vk::CommandBufferLevel::PRIMARY)
                        .command_buffer_count(1),
                )
                .vk("vkAllocateCommandBuffers")?[0];
            gpu.set_name(cb, label);
            let sizes = [
                vk::DescriptorPoolSize { ty: vk::DescriptorType::STORAGE_IMAGE, descriptor_count: 8192 },
                vk::DescriptorPoolSize { ty: vk::DescriptorType::STORAGE_BUFFER, descriptor_count: 8192 },
                vk::DescriptorPoolSize { ty: vk::DescriptorType::UNIFORM_BUFFER, descriptor_count: 64 },
            ];
            let descriptor_pool = device
                .create_descriptor_pool(
                    &vk::DescriptorPoolCreateInfo::default().max_sets(2048).pool_sizes(&sizes),
                    None,
                )
                .vk("vkCreateDescriptorPool")?;
            let query_pool = if gpu.shared.timestamps && !twin_checks {
                let pool = device
                    .create_query_pool(
                        &vk::QueryPoolCreateInfo::default()
                            .query_type(vk::QueryType::TIMESTAMP)
                            .query_count(MAX_TIMED_SPANS * 2),
                        None,
                    )
                    .vk("vkCreateQueryPool")?;
                Some(pool)
            } else {
                None
            };
            device
                .begin_command_buffer(
                    cb,
                    &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .vk("vkBeginCommandBuffer")?;
            if let Some(pool) = query_pool {
                device.cmd_reset_query_pool(cb, pool, 0, MAX_TIMED_SPANS * 2);
            }
            Ok(Recorder {
                gpu: gpu.clone(),
                command_pool,
                cb,
                descriptor_pool,
                query_pool,
                spans: Vec::new(),
                open_span: None,
                staging: Vec::new(),
                downloads: Vec::new(),
                layouts: Vec::new(),
                images: Vec::new(),
                buffers: Vec::new(),
                twin_checks: twin_checks.then(Vec::new),
            })
        }
    }

    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    pub fn command_buffer(&self) -> vk::CommandBuffer {
        self.cb
    }

    /// Open a named span: a debug label for profilers and a timestamp for `--profile`.
    pub fn begin_pass(&mut self, name: &str) {
        self.end_pass();
        let index = self.spans.len();
        self.spans.push(name.to_string());
        if let (Some(d), None) = (&self.gpu.shared.debug_device, &self.twin_checks) {
            if let Ok(label) = CString::new(name) {
                let info = vk::DebugUtilsLabelEXT::default().label_name(&label).color([0.2, 0.6, 0.9, 1.0]);
                unsafe { d.cmd_begin_debug_utils_label(self.cb, &info) };
            }
        }
        if let (Some(pool), true) = (self.query_pool, (index as u32) < MAX_TIMED_SPANS) {
            unsafe { self.gpu.cmd_timestamp(self.cb, pool, index as u32 * 2) };
        }
        self.open_span = Some(index);
    }

    /// Close the open span, if any.
    pub fn end_pass(&mut self) {
        let Some(index) = self.open_span.take() else { return };
        if let (Some(pool), true) = (self.query_pool, (index as u32) < MAX_TIMED_SPANS) {
            unsafe { self.gpu.cmd_timestamp(self.cb, pool, index as u32 * 2 + 1) };
        }
        if let (Some(d), None) = (&self.gpu.shared.debug_device, &self.twin_checks) {
            unsafe { d.cmd_end_debug_utils_label(self.cb) };
        }
    }

    /// Record a pipeline barrier made of image barriers (each pass writes its own).
    pub fn image_barriers(&mut self, barriers: &[vk::ImageMemoryBarrier2<'_>]) {
        self.layouts.extend(barriers.iter().map(|b| (b.image, b.new_layout)));
        let info = vk::DependencyInfo::default().image_memory_barriers(barriers);
        unsafe { self.gpu.cmd_barrier(self.cb, &info) };
    }

    /// Record a pipeline barrier made of buffer barriers.
    pub fn buffer_barriers(&mut self, barriers: &[vk::BufferMemoryBarrier2<'_>]) {
        let info = vk::DependencyInfo::default().buffer_memory_barriers(barriers);
        unsafe { self.gpu.cmd_barrier(self.cb, &info) };
    }

    /// Record a global memory barrier.
    pub fn memory_barrier(&mut self, barrier: vk::MemoryBarrier2<'_>) {
        let barriers = [barrier];
        let info = vk::DependencyInfo::default().memory_barriers(&barriers);
        unsafe { self.gpu.cmd_barrier(self.cb, &info) };
    }

    /// Fill a device buffer with a 32-bit value (a transfer write; the caller's next barrier
    /// makes it visible).
    pub fn fill_buffer(&mut self, buffer: &GpuBuffer, value: u32) {
        unsafe { self.gpu.device().cmd_fill_buffer(self.cb, buffer.buffer, 0, vk::WHOLE_SIZE, value) };
    }

    /// A storage image (also a copy source and target) that lives until the recording is
    /// dropped, after the submission completed.
    pub fn create_image(
        &mut self,
        name: &str,
        width: u32,
        height: u32,
        format: vk::Format,
    ) -> GpuResult<Arc<GpuImage>> {
        let image = Arc::new(self.gpu.create_image(name, width, height, format)?);
        self.images.push(image.clone());
        Ok(image)
    }

    /// A buffer of `words` u32 counters and indirect dispatch arguments: read by indirect
    /// dispatches, cleared by fills, written by shaders (atomics).
    pub fn create_args_buffer(&mut self, name: &str, words: u32) -> GpuResult<Arc<GpuBuffer>> {
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::INDIRECT_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST;
        self.create_buffer(name, words as u64 * 4, usage)
    }

    /// A device-local buffer that lives until the recording is dropped.
    pub fn create_buffer(
        &mut self,
        name: &str,
        size_bytes: u64,
        usage: vk::BufferUsageFlags,
    ) -> GpuResult<Arc<GpuBuffer>> {
        // Also a copy source: twin checks read every buffer back.
        let usage = usage | vk::BufferUsageFlags::TRANSFER_SRC;
        let buffer = Arc::new(self.gpu.create_buffer(name, size_bytes, usage, MemoryLocation::GpuOnly)?);
        self.buffers.push(buffer.clone());
        Ok(buffer)
    }

    /// Bind `pipeline` with a fresh descriptor set holding `binds`, push the constants, dispatch.
    /// Reached through [`Kernel::dispatch`](super::Kernel::dispatch), which knows the twin.
    pub(crate) fn dispatch(
        &mut self,
        pipeline: &ComputePipeline,
        binds: &[Bind<'_>],
        push_constants: &[u8],
        groups: [u32; 3],
        twin: TwinFn,
    ) -> GpuResult<()> {
        self.record_dispatch(pipeline, binds, push_constants, Groups::Direct(groups.map(|g| g.max(1))), twin)
    }

    /// Like [`Recorder::dispatch`], with the group counts read from `args` at `offset_bytes`
    /// (written by an earlier pass).
    pub(crate) fn dispatch_indirect(
        &mut self,
        pipeline: &ComputePipeline,
        binds: &[Bind<'_>],
        push_constants: &[u8],
        args: &GpuBuffer,
        offset_bytes: u64,
        twin: TwinFn,
    ) -> GpuResult<()> {
        self.record_dispatch(pipeline, binds, push_constants, Groups::Indirect(args, offset_bytes), twin)
    }

    fn record_dispatch(
        &mut self,
        pipeline: &ComputePipeline,
        binds: &[Bind<'_>],
        push_constants: &[u8],
        groups: Groups<'_>,
        twin: TwinFn,
    ) -> GpuResult<()> {
        check_binds(pipeline.name, &pipeline.bindings, binds)?;
        let before = match self.twin_checks {
            Some(_) => Some(self.read_back(binds, groups)?),
            None => None,
        };
        self.bind(pipeline, binds, push_constants)?;
        let device = self.gpu.device();
        match groups {
            Groups::Direct(g) => unsafe { device.cmd_dispatch(self.cb, g[0], g[1], g[2]) },
            Groups::Indirect(args, offset) => unsafe { device.cmd_dispatch_indirect(self.cb, args.buffer, offset) },
        }
        if let Some((mut twin_data, counts)) = before {
            let (mut gpu_data, _) = self.read_back(binds, Groups::Direct(counts))?;
            (twin.run)(push_constants, counts, &mut twin_data);
            (twin.canonical)(push_constants, &mut twin_data);
            (twin.canonical)(push_constants, &mut gpu_data);
            let result = compare_with_twin(pipeline.name, &pipeline.bindings, &gpu_data, &twin_data, twin.tolerance);
            let pass = self.open_span.and_then(|i| self.spans.get(i)).cloned().unwrap_or_default();
            if let Some(checks) = self.twin_checks.as_mut() {
                checks.push(TwinCheck { pass, shader: pipeline.name, groups: counts, result });
            }
        }
        Ok(())
    }

    /// Twin checks: submit what is recorded so far, then copy every bound resource back to the
    /// host (images from layout GENERAL), with the workgroup counts of the dispatch.
    fn read_back(&mut self, binds: &[Bind<'_>], groups: Groups<'_>) -> GpuResult<(Vec<HostData>, [u32; 3])> {
        self.flush()?;
        let mut staged = Vec::new();
        let device = self.gpu.device().clone();
        let copy_buffer = |rec: &mut Recorder, source: vk::Buffer, offset: u64, size: u64| -> GpuResult<GpuBuffer> {
            let staging = rec.gpu.create_buffer(
                "twin check read-back",
                size,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?;
            let region = vk::BufferCopy { src_offset: offset, dst_offset: 0, size };
            unsafe { device.cmd_copy_buffer(rec.cb, source, staging.buffer, &[region]) };
            Ok(staging)
        };
        // Every bound image is in GENERAL (the passes' own barriers put it there): to the copy's
        // layout for the read-back, and back. The flush's global barrier already ordered the
        // copies after everything recorded before.
        let layout = |image: &GpuImage, from: vk::ImageLayout, to: vk::ImageLayout| {
            vk::ImageMemoryBarrier2::default()
                .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
                .dst_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                .dst_access_mask(vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE)
                .old_layout(from)
                .new_layout(to)
                .image(image.image)
                .subresource_range(color_range())
        };
        let images: Vec<&GpuImage> =
            binds.iter().filter_map(|b| if let Bind::Image(i) = b { Some(*i) } else { None }).collect();
        let (general, transfer) = (vk::ImageLayout::GENERAL, vk::ImageLayout::TRANSFER_SRC_OPTIMAL);
        self.image_barriers(&images.iter().map(|i| layout(i, general, transfer)).collect::<Vec<_>>());
        for b in binds {
            staged.push(match b {
                Bind::Image(image) => {
                    let size = image.width as u64 * image.height as u64 * image.channels() as u64 * 4;
                    let staging = self.gpu.create_buffer(
                        "twin check read-back",
                        size,
                        vk::BufferUsageFlags::TRANSFER_DST,
                        MemoryLocation::GpuToCpu,
                    )?;
                    let region = buffer_image_region(image);
                    unsafe {
                        device.cmd_copy_image_to_buffer(self.cb, image.image, transfer, staging.buffer, &[region])
                    };
                    staging
                }
                Bind::Buffer(buffer) => copy_buffer(self, buffer.buffer, 0, buffer.size_bytes)?,
            });
        }
        let args = match groups {
            Groups::Indirect(args, offset) => Some(copy_buffer(self, args.buffer, offset, 12)?),
            Groups::Direct(_) => None,
        };
        self.image_barriers(&images.iter().map(|i| layout(i, transfer, general)).collect::<Vec<_>>());
        // Copy writes -> host reads after the fence.
        self.memory_barrier(
            vk::MemoryBarrier2::default()
                .src_stage_mask(vk::PipelineStageFlags2::COPY)
                .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
                .dst_stage_mask(vk::PipelineStageFlags2::HOST)
                .dst_access_mask(vk::AccessFlags2::HOST_READ),
        );
        self.flush()?;
        let data = binds
            .iter()
            .zip(&staged)
            .map(|(b, staging)| match b {
                Bind::Image(image) => {
                    HostData::Image(HostImage::new(image.width, image.height, image.channels(), staging.read_f32()))
                }
                Bind::Buffer(_) => HostData::Buffer(staging.read_u32()),
            })
            .collect();
        let counts = match (groups, args) {
            (Groups::Direct(g), _) => g,
            (Groups::Indirect(..), Some(a)) => {
                let w = a.read_u32();
                [w[0], w[1], w[2]]
            }
            (Groups::Indirect(..), None) => [0; 3],
        };
        Ok((data, counts))
    }

    /// Twin checks: end and submit the command buffer, wait, and continue in a new one whose
    /// first barrier orders everything after everything before (memory writes made available
    /// and visible), so the split changes nothing for the passes.
    fn flush(&mut self) -> GpuResult<()> {
        let device = self.gpu.device().clone();
        unsafe {
            device.end_command_buffer(self.cb).vk("vkEndCommandBuffer")?;
            self.gpu.submit_and_wait(self.cb)?;
            self.cb = device
                .allocate_command_buffers(
                    &vk::CommandBufferAllocateInfo::default()
                        .command_pool(self.command_pool)
                        .level(vk::CommandBufferLevel::PRIMARY)
                        .command_buffer_count(1),
                )
                .vk("vkAllocateCommandBuffers")?[0];
            device
                .begin_command_buffer(
                    self.cb,
                    &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .vk("vkBeginCommandBuffer")?;
        }
        self.memory_barrier(
            vk::MemoryBarrier2::default()
                .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
                .dst_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                .dst_access_mask(vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE),
        );
        Ok(())
    }

    fn bind(&mut self, pipeline: &ComputePipeline, binds: &[Bind<'_>], push_constants: &[u8]) -> GpuResult<()> {
        let device = self.gpu.device();
        unsafe {
            let layouts = [pipeline.set_layout];
            let set = device
                .allocate_descriptor_sets(
                    &vk::DescriptorSetAllocateInfo::default()
                        .descriptor_pool(self.descriptor_pool)
                        .set_layouts(&layouts),
                )
                .vk("vkAllocateDescriptorSets")?[0];
            for (i, b) in binds.iter().enumerate() {
                let write = vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(i as u32)
                    .descriptor_type(pipeline.bindings[i].kind.descriptor_type());
                match b {
                    Bind::Image(img) => {
                        let info = [vk::DescriptorImageInfo {
                            sampler: vk::Sampler::null(),
                            image_view: img.view,
                            image_layout: vk::ImageLayout::GENERAL,
                        }];
                        device.update_descriptor_sets(&[write.image_info(&info)], &[]);
                    }
                    Bind::Buffer(buf) => {
                        let info = [vk::DescriptorBufferInfo { buffer: buf.buffer, offset: 0, range: vk::WHOLE_SIZE }];
                        device.update_descriptor_sets(&[write.buffer_info(&info)], &[]);
                    }
                }
            }
            device.cmd_bind_pipeline(self.cb, vk::PipelineBindPoint::COMPUTE, pipeline.pipeline);
            device.cmd_bind_descriptor_sets(self.cb, vk::PipelineBindPoint::COMPUTE, pipeline.layout, 0, &[set], &[]);
            if !push_constants.is_empty() {
                device.cmd_push_constants(self.cb, pipeline.layout, vk::ShaderStageFlags::COMPUTE, 0, push_constants);
            }
        }
        Ok(())
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
        // Copy writes -> compute reads.
        self.buffer_barriers(&[vk::BufferMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COPY)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ)
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

    /// Submit, wait, and return the per-pass GPU times and the read-back data (indexed by the
    /// [`Download`] handles, in order).
    pub fn submit(self) -> GpuResult<(Profile, Vec<Vec<f32>>)> {
        self.submit_checked().map(|(profile, data, _)| (profile, data))
    }

    /// [`Recorder::submit`], also returning the twin checks of a recording made with
    /// [`Recorder::with_twin_checks`] (empty otherwise).
    pub fn submit_checked(mut self) -> GpuResult<(Profile, Vec<Vec<f32>>, Vec<TwinCheck>)> {
        self.end_pass();
        let device = self.gpu.device().clone();
        unsafe {
            device.end_command_buffer(self.cb).vk("vkEndCommandBuffer")?;
            let started = std::time::Instant::now();
            self.gpu.submit_and_wait(self.cb)?;
            let wall_ms = started.elapsed().as_secs_f64() * 1e3;
            let mut passes = Vec::new();
            if let Some(pool) = self.query_pool {
                let n = (self.spans.len() as u32).min(MAX_TIMED_SPANS);
                let mut stamps = vec![0u64; (n * 2) as usize];
                if n > 0 {
                    device
                        .get_query_pool_results(
                            pool,
                            0,
                            &mut stamps,
                            vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                        )
                        .vk("vkGetQueryPoolResults")?;
                }
                let period_ms = self.gpu.shared.timestamp_period_ns * 1e-6;
                let origin = stamps.first().copied().unwrap_or(0);
                for (i, name) in self.spans.iter().take(n as usize).enumerate() {
                    let (a, b) = (stamps[2 * i], stamps[2 * i + 1]);
                    passes.push(PassTiming {
                        name: name.clone(),
                        start_ms: a.saturating_sub(origin) as f64 * period_ms,
                        gpu_ms: b.saturating_sub(a) as f64 * period_ms,
                    });
                }
            }
            // The work completed: the images are in the layouts its barriers left them in.
            for image in &self.images {
                if let Some(&(_, layout)) = self.layouts.iter().rev().find(|(i, _)| *i == image.image) {
                    image.set_layout(layout);
                }
            }
            let data = std::mem::take(&mut self.downloads)
                .into_iter()
                .map(|readback| match readback {
                    Readback::Buffer(buffer) => buffer.read_f32(),
                    Readback::Image(image, channels, memory) => image.read_host(channels, memory),
                })
                .collect();
            let checks = self.twin_checks.take().unwrap_or_default();
            let profile = Profile {
                device: self.gpu.info().to_string(),
                passes,
                submit_wall_ms: wall_ms,
                submitted_at: Some(started),
            };
            Ok((profile, data, checks))
        }
    }
}

/// How many workgroups a dispatch runs.
#[derive(Clone, Copy)]
enum Groups<'a> {
    Direct([u32; 3]),
    /// Read from the buffer at the byte offset (VkDispatchIndirectCommand).
    Indirect(&'a GpuBuffer, u64),
}

/// The resources of a dispatch against the shader's declared bindings: one per binding, each
/// of the declared kind.
fn check_binds(shader: &'static str, declared: &[Binding], binds: &[Bind<'_>]) -> GpuResult<()> {
    if binds.len() != declared.len() {
        return Err(GpuError::Binding {
            shader,
            message: format!("{} resources bound to {} declared bindings", binds.len(), declared.len()),
        });
    }
    for (i, (b, d)) in binds.iter().zip(declared).enumerate() {
        let given = match b {
            Bind::Image(_) => BindingKind::StorageImage,
            Bind::Buffer(_) => BindingKind::StorageBuffer,
        };
        if given != d.kind && !(given == BindingKind::StorageBuffer && d.kind == BindingKind::UniformBuffer) {
            return Err(GpuError::Binding {
                shader,
                message: format!("binding {i} ({}) is {} but {given} was bound", d.name, d.kind),
            });
        }
    }
    Ok(())
}

impl Download {
    pub fn index(self) -> usize {
        self.0
    }
}

fn buffer_image_region(image: &GpuImage) -> vk::BufferImageCopy {
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

impl Drop for Recorder {
    fn drop(&mut self) {
        let device = self.gpu.device();
        unsafe {
            // The recording may be dropped unsubmitted after an error: wait so nothing in flight
            // still uses the staging buffers.
            let _ = device.device_wait_idle();
            if let Some(pool) = self.query_pool {
                device.destroy_query_pool(pool, None);
            }
            device.destroy_descriptor_pool(self.descriptor_pool, None);
            device.destroy_command_pool(self.command_pool, None);
        }
    }
}
