//! Checks of what a frame asks for against the device's limits, so that a
//! scene too large for the device is a typed error before wgpu sees it.

/// Largest image side nimbus renders, pixels (further bounded by the device).
pub const MAX_IMAGE_SIDE_PX: u32 = 16_384;

/// Largest image area nimbus renders, pixels (8192 × 8192): the HDR target
/// alone then takes 512 MiB.
pub const MAX_IMAGE_PIXELS: u64 = 8192 * 8192;

/// A request beyond the device's limits.
#[derive(Debug, thiserror::Error)]
pub enum LimitError {
    /// The image is larger than the device allows.
    #[error(
        "image size {width}×{height}: each side must be in [1, {max}] on this device, and the area at most {max_pixels} pixels"
    )]
    ImageSize {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
        /// The device's largest 2D texture side.
        max: u32,
        /// The largest area.
        max_pixels: u64,
    },
    /// A GPU buffer would exceed the device's limit.
    #[error("{what} needs a {bytes}-byte buffer; this device allows at most {max} bytes")]
    BufferTooLarge {
        /// What the buffer is for, naming the setting that sizes it.
        what: String,
        /// Bytes needed.
        bytes: u64,
        /// The device's `max_buffer_size`.
        max: u64,
    },
}

/// Checks an image size against the device's limits.
pub fn check_image_size(device: &wgpu::Device, width: u32, height: u32) -> Result<(), LimitError> {
    let max = device
        .limits()
        .max_texture_dimension_2d
        .min(MAX_IMAGE_SIDE_PX);
    let max_pixels = MAX_IMAGE_PIXELS;
    if width == 0
        || height == 0
        || width > max
        || height > max
        || width as u64 * height as u64 > max_pixels
    {
        return Err(LimitError::ImageSize {
            width,
            height,
            max,
            max_pixels,
        });
    }
    Ok(())
}

/// Checks that a buffer of `bytes` fits the device's limit.
pub fn check_buffer_size(device: &wgpu::Device, what: &str, bytes: u64) -> Result<(), LimitError> {
    let max = device.limits().max_buffer_size;
    if bytes > max {
        return Err(LimitError::BufferTooLarge {
            what: what.to_owned(),
            bytes,
            max,
        });
    }
    Ok(())
}
