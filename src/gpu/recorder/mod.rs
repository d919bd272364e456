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

mod dispatch;
mod transfer;

use transfer::buffer_image_region;

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
            let (gpu_memory_bytes, gpu_memory_held_bytes) = self.gpu.memory_bytes();
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
                gpu_memory_bytes,
                gpu_memory_held_bytes,
            };
            Ok((profile, data, checks))
        }
    }
}

impl Download {
    pub fn index(self) -> usize {
        self.0
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
