//! The images and buffers a recording let go of, kept for the next recording that asks for the
//! same kind. Every frame of a sequence creates the same images and buffers: created anew, each
//! cost its Vulkan objects and, on lavapipe, memory blocks that gpu-allocator gave back when
//! they emptied and took again the next frame, whose pages were then faulted in and zeroed again
//! by the first shader or copy to touch them (a 1280x720 sequence frame: about 7,800 page faults;
//! the kernel's share of a sequence's CPU time fell from 11% to 5% with the pool). A kept resource goes back out only to a request of the same
//! size, format or usage and memory location; the oldest go first past [`POOL_MAX_BYTES`].
//!
//! Only what was dropped is kept, and a resource is dropped only after the GPU work that used it
//! completed (the rule for destroying it, which the pool inherits), so a kept resource is idle.
//! Its contents are stale: every pass already treats a new image's contents as undefined (its
//! first barrier discards them) and clears what it counts in.

use ash::vk;
use gpu_allocator::vulkan::Allocation;
use gpu_allocator::MemoryLocation;
use std::collections::VecDeque;

/// The most memory the pool keeps idle (two 1280x720 frames' images fit with room to spare).
pub const POOL_MAX_BYTES: u64 = 1 << 30;

/// An idle image's parts (no handle to the device: the pool lives inside it).
pub(crate) struct PooledImage {
    pub image: vk::Image,
    pub view: vk::ImageView,
    pub allocation: Allocation,
    pub format: vk::Format,
    pub width: u32,
    pub height: u32,
}

/// An idle buffer's parts.
pub(crate) struct PooledBuffer {
    pub buffer: vk::Buffer,
    pub allocation: Allocation,
    pub size_bytes: u64,
    pub usage: vk::BufferUsageFlags,
    pub location: MemoryLocation,
}

pub(crate) enum Pooled {
    Image(PooledImage),
    Buffer(PooledBuffer),
}

impl Pooled {
    fn bytes(&self) -> u64 {
        match self {
            Pooled::Image(i) => i.allocation.size(),
            Pooled::Buffer(b) => b.allocation.size(),
        }
    }

    /// Destroy its Vulkan objects; its memory goes back to the allocator.
    pub fn destroy(self, device: &ash::Device) -> Allocation {
        unsafe {
            match self {
                Pooled::Image(i) => {
                    device.destroy_image_view(i.view, None);
                    device.destroy_image(i.image, None);
                    i.allocation
                }
                Pooled::Buffer(b) => {
                    device.destroy_buffer(b.buffer, None);
                    b.allocation
                }
            }
        }
    }
}

/// The idle resources, oldest first.
#[derive(Default)]
pub(crate) struct ResourcePool {
    idle: VecDeque<Pooled>,
    bytes: u64,
}

impl ResourcePool {
    /// Keep `item`; returns what no longer fits (the oldest first), for the caller to destroy.
    pub fn keep(&mut self, item: Pooled) -> Vec<Pooled> {
        self.bytes += item.bytes();
        self.idle.push_back(item);
        let mut evicted = Vec::new();
        while self.bytes > POOL_MAX_BYTES {
            let Some(old) = self.idle.pop_front() else { break };
            self.bytes -= old.bytes();
            evicted.push(old);
        }
        evicted
    }

    /// An idle image of this size and format (the newest: the likeliest still in the CPU's caches).
    pub fn take_image(&mut self, width: u32, height: u32, format: vk::Format) -> Option<PooledImage> {
        let at = self.idle.iter().rposition(
            |p| matches!(p, Pooled::Image(i) if i.width == width && i.height == height && i.format == format),
        )?;
        match self.remove(at)? {
            Pooled::Image(i) => Some(i),
            Pooled::Buffer(_) => None,
        }
    }

    /// An idle buffer of this size, usage and memory location.
    pub fn take_buffer(
        &mut self,
        size_bytes: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Option<PooledBuffer> {
        let at = self.idle.iter().rposition(|p| {
            matches!(p, Pooled::Buffer(b) if b.size_bytes == size_bytes && b.usage == usage && b.location == location)
        })?;
        match self.remove(at)? {
            Pooled::Buffer(b) => Some(b),
            Pooled::Image(_) => None,
        }
    }

    fn remove(&mut self, at: usize) -> Option<Pooled> {
        let item = self.idle.remove(at)?;
        self.bytes -= item.bytes();
        Some(item)
    }

    /// Everything idle, for destruction (the device is going away, or a caller trims).
    pub fn drain(&mut self) -> Vec<Pooled> {
        self.bytes = 0;
        self.idle.drain(..).collect()
    }

    pub fn idle_bytes(&self) -> u64 {
        self.bytes
    }

    pub fn idle_count(&self) -> usize {
        self.idle.len()
    }
}
