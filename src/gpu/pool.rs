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
    /// Its rows in mapped host memory, for an image there.
    pub host_rows: Option<super::resources::HostRows>,
    /// The layout its last recording left it in.
    pub layout: vk::ImageLayout,
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
    /// Destroy its Vulkan objects; its memory goes back to the allocator.
    pub fn destroy(self, device: &ash::Device) -> Allocation {
        // SAFETY: only resources dropped after the work that used them completed are kept
        // (the module's rule), so nothing in flight uses them; each is destroyed once, here.
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

/// What the pool keeps, by its size in memory.
pub(crate) trait Weighed {
    fn bytes(&self) -> u64;
}

impl Weighed for Pooled {
    fn bytes(&self) -> u64 {
        match self {
            Pooled::Image(i) => i.allocation.size(),
            Pooled::Buffer(b) => b.allocation.size(),
        }
    }
}

/// Idle items, oldest first, at most `max_bytes` of them.
pub(crate) struct IdleQueue<T> {
    idle: VecDeque<T>,
    bytes: u64,
    max_bytes: u64,
}

/// The device's idle images and buffers.
pub(crate) type ResourcePool = IdleQueue<Pooled>;

impl Default for ResourcePool {
    fn default() -> Self {
        IdleQueue::new(POOL_MAX_BYTES)
    }
}

impl<T: Weighed> IdleQueue<T> {
    pub fn new(max_bytes: u64) -> Self {
        IdleQueue { idle: VecDeque::new(), bytes: 0, max_bytes }
    }

    /// Keep `item`; returns what no longer fits (the oldest first), for the caller to destroy.
    pub fn keep(&mut self, item: T) -> Vec<T> {
        self.bytes += item.bytes();
        self.idle.push_back(item);
        let mut evicted = Vec::new();
        while self.bytes > self.max_bytes {
            let Some(old) = self.idle.pop_front() else { break };
            self.bytes -= old.bytes();
            evicted.push(old);
        }
        evicted
    }

    /// The newest idle item that `fits` (the likeliest still in the CPU's caches), taken out.
    pub fn take(&mut self, fits: impl Fn(&T) -> bool) -> Option<T> {
        let at = self.idle.iter().rposition(fits)?;
        let item = self.idle.remove(at)?;
        self.bytes -= item.bytes();
        Some(item)
    }

    /// Everything idle, for destruction (the device is going away, or a caller trims).
    pub fn drain(&mut self) -> Vec<T> {
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

impl ResourcePool {
    /// An idle image of this size and format.
    pub fn take_image(&mut self, width: u32, height: u32, format: vk::Format) -> Option<PooledImage> {
        let fits =
            |p: &Pooled| matches!(p, Pooled::Image(i) if i.width == width && i.height == height && i.format == format);
        match self.take(fits)? {
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
        let fits = |p: &Pooled| matches!(p, Pooled::Buffer(b) if b.size_bytes == size_bytes && b.usage == usage && b.location == location);
        match self.take(fits)? {
            Pooled::Buffer(b) => Some(b),
            Pooled::Image(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An item named by a number, of a size.
    #[derive(Debug, PartialEq)]
    struct Item(u32, u64);

    impl Weighed for Item {
        fn bytes(&self) -> u64 {
            self.1
        }
    }

    #[test]
    fn past_its_size_the_queue_lets_the_oldest_go_first() {
        let mut q = IdleQueue::new(100);
        assert!(q.keep(Item(1, 40)).is_empty());
        assert!(q.keep(Item(2, 40)).is_empty());
        // 120 bytes: the oldest goes.
        assert_eq!(q.keep(Item(3, 40)), vec![Item(1, 40)]);
        assert_eq!((q.idle_count(), q.idle_bytes()), (2, 80));
        // One larger than the whole queue: everything goes, itself last.
        assert_eq!(q.keep(Item(4, 150)), vec![Item(2, 40), Item(3, 40), Item(4, 150)]);
        assert_eq!((q.idle_count(), q.idle_bytes()), (0, 0));
    }

    #[test]
    fn a_request_takes_the_newest_item_that_fits_and_its_bytes_leave_the_count() {
        let mut q = IdleQueue::new(1000);
        for item in [Item(1, 10), Item(2, 20), Item(3, 10), Item(4, 30)] {
            q.keep(item);
        }
        assert_eq!(q.take(|i| i.1 == 10), Some(Item(3, 10)));
        assert_eq!(q.take(|i| i.1 == 10), Some(Item(1, 10)));
        assert_eq!(q.take(|i| i.1 == 10), None);
        assert_eq!((q.idle_count(), q.idle_bytes()), (2, 50));
        assert_eq!(q.drain(), vec![Item(2, 20), Item(4, 30)]);
        assert_eq!((q.idle_count(), q.idle_bytes()), (0, 0));
    }
}
