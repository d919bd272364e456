//! Images and buffers, all memory through gpu-allocator, every object named for debuggers.

use super::context::Shared;
use super::pool::{Pooled, PooledBuffer, PooledImage};
use super::{Gpu, GpuError, GpuResult, VkContext};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;
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
            });
        }
        let device = self.device();
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D { width: width.max(1), height: height.max(1), depth: 1 })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        unsafe {
            let image = device.create_image(&info, None).vk("vkCreateImage")?;
            let requirements = device.get_image_memory_requirements(image);
            let allocation = self.allocate(name, requirements, MemoryLocation::GpuOnly, false);
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
            Ok(GpuImage {
                shared: self.shared.clone(),
                image,
                view,
                allocation: Some(allocation),
                format,
                width,
                height,
                name: name.to_string(),
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
