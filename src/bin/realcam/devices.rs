//! `realcam devices`: the Vulkan devices.

use anyhow::Result;
use realcam::gpu::Gpu;

pub fn run() -> Result<()> {
    for d in Gpu::list_devices()? {
        println!("[{}] {}", d.index, d);
    }
    Ok(())
}
