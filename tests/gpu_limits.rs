//! What the device cannot hold is an error naming it, before Vulkan is asked (lavapipe in CI,
//! validation on: creating such an image would be invalid usage).

mod support;

use ash::vk;
use support::{assert_validation_clean, gpu};

#[test]
fn an_image_beyond_the_device_limit_is_an_error_naming_it() {
    let gpu = gpu();
    let mut rec = realcam::gpu::Recorder::new(&gpu, "limits test").unwrap();
    // An image of exactly the limit's width (one row) is fine; one more pixel is not.
    let max_px = gpu.max_image_dimension_px();
    rec.create_image("widest", max_px, 1, vk::Format::R32_SFLOAT).unwrap();
    let err = match rec.create_image("aperture shape table", max_px + 1, max_px + 1, vk::Format::R32_SFLOAT) {
        Ok(_) => panic!("an image of {0}x{0} px was made", max_px + 1),
        Err(e) => e,
    };
    assert_eq!(
        err.to_string(),
        format!(
            "the image \"aperture shape table\" of {0}x{0} px does not fit the device {1:?}: its images may be at most {max_px} px on a side",
            max_px + 1,
            gpu.info().name
        )
    );
    drop(rec);
    assert_validation_clean(&gpu);
}
