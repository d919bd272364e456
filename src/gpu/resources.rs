//! Images and buffers, all memory through gpu-allocator, every object named for debuggers.

use super::context::Shared;
use super::pool::{Pooled, PooledBuffer, PooledImage};
use super::{Gpu, GpuError, GpuResult, VkContext};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;
use std::sync::atomic::{AtomicI32, Ordering};
use std::sync::Arc;

/// A 2D image used as a storage image by compute passes (layout GENERAL while in use).
pub struct GpuImage {
    shared: Arc<Shared>,
    pub image: vk::Image,
    pub view: vk::ImageView,
    allocation: Option<Allocation>,
    pub format: vk::Format,
    pub width: u32,
    pub height: u32,
    pub name: String,
    /// Where its rows lie in its mapped memory, for an image in host memory (see
    /// [`Gpu::create_image`]); `None` for one the host cannot reach.
    host_rows: Option<HostRows>,
    /// The layout the last completed recording that used it left it in (the recorder sets the
    /// last new layout of its barriers after the submission): host access needs PREINITIALIZED
    /// or GENERAL.
    layout: AtomicI32,
}

/// The rows of a linear image in mapped memory: the first row's byte offset from the
/// allocation's start and the bytes from one row to the next.
#[derive(Clone, Copy, Debug)]
pub(crate) struct HostRows {
    pub offset_bytes: u64,
    pub row_pitch_bytes: u64,
}

/// A buffer: host-visible staging memory or device-local storage.
pub struct GpuBuffer {
    shared: Arc<Shared>,
    pub buffer: vk::Buffer,
    allocation: Option<Allocation>,
    pub size_bytes: u64,
    pub name: String,
    usage: vk::BufferUsageFlags,
    location: MemoryLocation,
}

impl Gpu {
    /// A storage image that can also be the source and target of copies.
    /// An image wider or taller than the device allows is an error naming it (creating it
    /// would be invalid usage).
    pub fn create_image(&self, name: &str, width: u32, height: u32, format: vk::Format) -> GpuResult<GpuImage> {
        let max_px = self.max_image_dimension_px();
        if width > max_px || height > max_px {
            let device = self.info().name.clone();
            return Err(GpuError::ImageTooLarge { name: name.into(), device, width, height, max_px });
        }
        let reused = self.shared.pool.lock().ok().and_then(|mut p| p.take_image(width, height, format));
        if let Some(p) = reused {
            self.set_name(p.image, name);
            self.set_name(p.view, name);
            return Ok(GpuImage {
                shared: self.shared.clone(),
                image: p.image,
                view: p.view,
                allocation: Some(p.allocation),
                format,
                width,
                height,
                name: name.to_string(),
                host_rows: p.host_rows,
                layout: AtomicI32::new(p.layout.as_raw()),
            });
        }
        // On a device that runs on the CPU, device memory is the host's: the image is linear in
        // mapped memory, so that the host writes an upload into it and reads a result out of it
        // directly (Recorder::upload_images, Recorder::download_image). A staging buffer
        // between them would cost a copy of the frame and its pages' first touch (scene A's
        // colour and depth: 18 MB, 4,600 page faults).
        let in_host_memory = self.shared.host_image_formats.contains(&format);
        let (tiling, initial_layout, location) = match in_host_memory {
            true => (vk::ImageTiling::LINEAR, vk::ImageLayout::PREINITIALIZED, MemoryLocation::CpuToGpu),
            false => (vk::ImageTiling::OPTIMAL, vk::ImageLayout::UNDEFINED, MemoryLocation::GpuOnly),
        };
        let device = self.device();
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D { width: width.max(1), height: height.max(1), depth: 1 })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(tiling)
            .usage(vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(initial_layout);
        unsafe {
            let image = device.create_image(&info, None).vk("vkCreateImage")?;
            let requirements = device.get_image_memory_requirements(image);
            let allocation = self.allocate(name, requirements, location, in_host_memory);
            let allocation = match allocation {
                Ok(a) => a,
                Err(e) => {
                    device.destroy_image(image, None);
                    return Err(e);
                }
            };
            device.bind_image_memory(image, allocation.memory(), allocation.offset()).vk("vkBindImageMemory")?;
            let view_info = vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(format)
                .subresource_range(color_range());
            let view = device.create_image_view(&view_info, None).vk("vkCreateImageView")?;
            self.set_name(image, name);
            self.set_name(view, name);
            let mapped = allocation.mapped_ptr().is_some();
            let host_rows = (in_host_memory && mapped).then(|| {
                let subresource =
                    vk::ImageSubresource { aspect_mask: vk::ImageAspectFlags::COLOR, mip_level: 0, array_layer: 0 };
                let rows = device.get_image_subresource_layout(image, subresource);
                HostRows { offset_bytes: rows.offset, row_pitch_bytes: rows.row_pitch }
            });
            Ok(GpuImage {
                shared: self.shared.clone(),
                image,
                view,
                allocation: Some(allocation),
                format,
                width,
                height,
                name: name.to_string(),
                host_rows,
                layout: AtomicI32::new(initial_layout.as_raw()),
            })
        }
    }

    /// A buffer in the given memory location (`CpuToGpu` for uploads, `GpuToCpu` for read-back).
    pub fn create_buffer(
        &self,
        name: &str,
        size_bytes: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> GpuResult<GpuBuffer> {
        let reused = self.shared.pool.lock().ok().and_then(|mut p| p.take_buffer(size_bytes, usage, location));
        if let Some(p) = reused {
            self.set_name(p.buffer, name);
            return Ok(GpuBuffer {
                shared: self.shared.clone(),
                buffer: p.buffer,
                allocation: Some(p.allocation),
                size_bytes,
                name: name.to_string(),
                usage,
                location,
            });
        }
        let device = self.device();
        let info = vk::BufferCreateInfo::default()
            .size(size_bytes.max(4))
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        unsafe {
            let buffer = device.create_buffer(&info, None).vk("vkCreateBuffer")?;
            let requirements = device.get_buffer_memory_requirements(buffer);
            let allocation = match self.allocate(name, requirements, location, true) {
                Ok(a) => a,
                Err(e) => {
                    device.destroy_buffer(buffer, None);
                    return Err(e);
                }
            };
            device.bind_buffer_memory(buffer, allocation.memory(), allocation.offset()).vk("vkBindBufferMemory")?;
            self.set_name(buffer, name);
            Ok(GpuBuffer {
                shared: self.shared.clone(),
                buffer,
                allocation: Some(allocation),
                size_bytes,
                name: name.to_string(),
                usage,
                location,
            })
        }
    }

    fn allocate(
        &self,
        name: &str,
        requirements: vk::MemoryRequirements,
        location: MemoryLocation,
        linear: bool,
    ) -> GpuResult<Allocation> {
        let mut guard = self.shared.allocator.lock().unwrap_or_else(|p| p.into_inner());
        let allocator = guard.as_mut().ok_or(GpuError::AllocatorGone)?;
        allocator
            .allocate(&AllocationCreateDesc {
                name,
                requirements,
                location,
                linear,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            })
            .map_err(|source| GpuError::Alloc { name: name.to_string(), source })
    }
}

impl GpuImage {
    /// f32 channels per texel (the formats realcam uses: R32F and RGBA32F).
    pub fn channels(&self) -> u32 {
        match self.format {
            vk::Format::R32_SFLOAT => 1,
            vk::Format::R32G32_SFLOAT => 2,
            _ => 4,
        }
    }

    /// The layout the last completed recording left it in.
    pub(crate) fn layout(&self) -> vk::ImageLayout {
        vk::ImageLayout::from_raw(self.layout.load(Ordering::Relaxed))
    }

    /// Set by the recorder once the recording that moved it to `layout` completed.
    pub(crate) fn set_layout(&self, layout: vk::ImageLayout) {
        self.layout.store(layout.as_raw(), Ordering::Relaxed);
    }

    /// Whether the host may write it now, as it was left: in mapped host memory and in a
    /// layout that allows host access (PREINITIALIZED or GENERAL).
    pub(crate) fn host_writable(&self) -> bool {
        self.host_rows.is_some() && matches!(self.layout(), vk::ImageLayout::PREINITIALIZED | vk::ImageLayout::GENERAL)
    }

    /// Whether it lies in mapped host memory (its texels can be read there once the work that
    /// wrote them completed and was made visible to the host).
    pub fn in_host_memory(&self) -> bool {
        self.host_rows.is_some()
    }

    /// Its mapped memory's start, its rows, and the bytes of a row of `channels` f32 texels;
    /// `None` for an image the host cannot reach, or whose rows would not fit its allocation.
    fn host_row_ptrs(&self, channels: u32) -> Option<(*mut u8, HostRows, usize)> {
        let rows = self.host_rows?;
        let base = self.allocation.as_ref()?.mapped_ptr()?.as_ptr().cast::<u8>();
        let row_bytes = self.width as usize * channels as usize * 4;
        let last =
            rows.offset_bytes as usize + rows.row_pitch_bytes as usize * (self.height as usize).saturating_sub(1);
        let size = self.allocation.as_ref()?.size() as usize;
        (row_bytes <= rows.row_pitch_bytes as usize && last + row_bytes <= size).then_some((base, rows, row_bytes))
    }

    /// Writes `data` (`width * height * channels` values, row by row) into the image's mapped
    /// memory; false (nothing written) for an image the host cannot reach or data of another
    /// size.
    ///
    /// # Safety
    /// No GPU work that uses the image may be pending or running: it is new, or from the idle
    /// pool, and not yet used by the recording that uploads into it.
    pub(crate) unsafe fn write_host(&self, data: &[f32]) -> bool {
        let Some((base, rows, row_bytes)) = self.host_row_ptrs(self.channels()) else { return false };
        let bytes: &[u8] = bytemuck::cast_slice(data);
        if bytes.len() != row_bytes * self.height as usize {
            return false;
        }
        for (y, row) in bytes.chunks_exact(row_bytes.max(1)).enumerate() {
            let at = rows.offset_bytes as usize + y * rows.row_pitch_bytes as usize;
            std::ptr::copy_nonoverlapping(row.as_ptr(), base.add(at), row_bytes);
        }
        true
    }

    /// The image's texels from its mapped memory (`channels` f32 per texel, row by row), in
    /// `values`' allocation (grown if it is too small); empty for an image the host cannot
    /// reach. Call after the work that wrote it completed, with its writes made visible to the
    /// host.
    pub(crate) fn read_host(&self, channels: u32, mut values: Vec<f32>) -> Vec<f32> {
        values.clear();
        let Some((base, rows, row_bytes)) = self.host_row_ptrs(channels) else { return values };
        values.resize(row_bytes / 4 * self.height as usize, 0.0);
        let out: &mut [u8] = bytemuck::cast_slice_mut(&mut values);
        for (y, row) in out.chunks_exact_mut(row_bytes.max(1)).enumerate() {
            let at = rows.offset_bytes as usize + y * rows.row_pitch_bytes as usize;
            // SAFETY: host_row_ptrs checked that every row lies inside the mapped allocation.
            unsafe { std::ptr::copy_nonoverlapping(base.add(at), row.as_mut_ptr(), row_bytes) };
        }
        values
    }
}

pub fn color_range() -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}

impl GpuBuffer {
    /// What the buffer was created for.
    pub fn usage(&self) -> vk::BufferUsageFlags {
        self.usage
    }

    /// Copy bytes into a host-visible buffer.
    pub fn write_bytes(&mut self, bytes: &[u8]) {
        if let Some(slice) = self.allocation.as_mut().and_then(|a| a.mapped_slice_mut()) {
            let n = bytes.len().min(slice.len());
            slice[..n].copy_from_slice(&bytes[..n]);
        }
    }

    /// Read a host-visible buffer as f32 values (one copy, as bytes: the mapping may not be
    /// aligned for f32).
    pub fn read_f32(&self) -> Vec<f32> {
        self.allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .map(|s| {
                let n = self.size_bytes as usize / 4;
                let mut values = vec![0f32; n];
                bytemuck::cast_slice_mut::<f32, u8>(&mut values).copy_from_slice(&s[..n * 4]);
                values
            })
            .unwrap_or_default()
    }

    /// Read a host-visible buffer as u32 values.
    pub fn read_u32(&self) -> Vec<u32> {
        self.read_f32().into_iter().map(f32::to_bits).collect()
    }
}

/// Dropped after the work that used it completed: kept idle for the next frame's same image.
impl Drop for GpuImage {
    fn drop(&mut self) {
        if let Some(allocation) = self.allocation.take() {
            self.shared.release(Pooled::Image(PooledImage {
                image: self.image,
                view: self.view,
                allocation,
                format: self.format,
                width: self.width,
                height: self.height,
                host_rows: self.host_rows,
                layout: self.layout(),
            }));
        }
    }
}

/// Dropped after the work that used it completed: kept idle for the next frame's same buffer.
impl Drop for GpuBuffer {
    fn drop(&mut self) {
        if let Some(allocation) = self.allocation.take() {
            self.shared.release(Pooled::Buffer(PooledBuffer {
                buffer: self.buffer,
                allocation,
                size_bytes: self.size_bytes,
                usage: self.usage,
                location: self.location,
            }));
        }
    }
}
