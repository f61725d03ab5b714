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
    /// A software adapter (whose device memory is the process's own) has
    /// not the memory a frame's targets need: refused before allocating,
    /// because a software driver that runs out may end the process instead
    /// of reporting it (Mesa 25's lavapipe does).
    #[error(
        "a {width}×{height} frame needs about {needed_mib} MiB of GPU memory (its targets and the driver's work) and the software adapter has {available_mib} MiB left (the process's address-space limit or the machine's free memory): try a smaller image"
    )]
    FrameMemory {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
        /// What the frame's targets and the driver's work take, MiB.
        needed_mib: u64,
        /// What the process can still allocate, MiB.
        available_mib: u64,
    },
}

/// What a frame claims per pixel on a software adapter, bytes: nimbus's HDR
/// target (8), its own depth in `LinearHdr` (4), the cumulus fringes'
/// accumulation and revealage (8 + 2), a headless renderer's output and
/// depth (4 + 4) and their read-backs (12), and the driver's own copies
/// and bins. Measured on lavapipe (Mesa 25.0, the default scene): the
/// process's address space grew by 64–88 bytes per pixel from 64×64 to
/// 2048² and 4096².
pub const FRAME_BYTES_PER_PIXEL: u64 = 80;

/// What a software adapter claims after the check, whatever the frame's
/// size, bytes: the pipelines' compiled code, the scene's buffers (terrain,
/// rain, clouds, shadow maps), the rasterizer's threads. Measured on
/// lavapipe (Mesa 25.0, the default scene at 64×64): 0.45 GiB of address
/// space with two rasterizer threads and two malloc arenas, 0.85 GiB with
/// glibc's default arenas.
const SOFTWARE_DRIVER_HEADROOM_BYTES: u64 = 768 << 20;

/// On a software adapter (device type `Cpu`, whose device memory is the
/// process's), checks that a `width`×`height` frame's targets fit in what
/// the process can still allocate; nothing is checked on other adapters
/// (their drivers report out-of-memory) or where the process's memory
/// cannot be read.
pub fn check_frame_memory(
    device: &wgpu::Device,
    width: u32,
    height: u32,
) -> Result<(), LimitError> {
    if device.adapter_info().device_type != wgpu::DeviceType::Cpu {
        return Ok(());
    }
    let Some(available) = process_memory_available_bytes() else {
        return Ok(());
    };
    let needed = (u64::from(width) * u64::from(height) * FRAME_BYTES_PER_PIXEL)
        .saturating_add(SOFTWARE_DRIVER_HEADROOM_BYTES);
    if needed > available {
        return Err(LimitError::FrameMemory {
            width,
            height,
            needed_mib: needed.div_ceil(1 << 20),
            available_mib: available >> 20,
        });
    }
    Ok(())
}

/// What this process can still allocate, bytes: the smaller of the room
/// left under its address-space limit (`ulimit -v`: the limit less the
/// virtual size it already has) and the machine's available memory; `None`
/// where `/proc` does not tell (not Linux).
pub fn process_memory_available_bytes() -> Option<u64> {
    let read = |path: &str| std::fs::read_to_string(path).ok();
    let free = read("/proc/meminfo").and_then(|text| kib_field(&text, "MemAvailable:"))?;
    let room = read("/proc/self/limits")
        .and_then(|text| address_space_limit_bytes(&text))
        .zip(read("/proc/self/status").and_then(|text| kib_field(&text, "VmSize:")))
        .map(|(limit, used)| limit.saturating_sub(used));
    Some(room.map_or(free, |room| room.min(free)))
}

/// A `NAME:   1234 kB` line of `/proc/meminfo` or `/proc/self/status`, bytes.
fn kib_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|line| line.starts_with(name))?;
    let kib: u64 = line[name.len()..].split_whitespace().next()?.parse().ok()?;
    Some(kib * 1024)
}

/// The soft limit of `Max address space` in `/proc/self/limits`, bytes;
/// `None` when unlimited.
fn address_space_limit_bytes(limits: &str) -> Option<u64> {
    let line = limits
        .lines()
        .find(|line| line.starts_with("Max address space"))?;
    line["Max address space".len()..]
        .split_whitespace()
        .next()?
        .parse()
        .ok()
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proc_fields_are_read_in_bytes() {
        let status = "Name:\tnimbus\nVmPeak:\t 2000 kB\nVmSize:\t 1536 kB\n";
        assert_eq!(kib_field(status, "VmSize:"), Some(1536 * 1024));
        assert_eq!(kib_field(status, "VmRSS:"), None);
        let meminfo = "MemTotal:       24000000 kB\nMemAvailable:   20000000 kB\n";
        assert_eq!(kib_field(meminfo, "MemAvailable:"), Some(20_000_000 * 1024));
    }

    #[test]
    fn the_address_space_limit_is_the_soft_limit_or_none_when_unlimited() {
        let limited = "Limit                     Soft Limit           Hard Limit           Units     \n\
                       Max stack size            8388608              unlimited            bytes     \n\
                       Max address space         1879048192           unlimited            bytes     \n";
        assert_eq!(address_space_limit_bytes(limited), Some(1_879_048_192));
        let unlimited =
            "Max address space         unlimited            unlimited            bytes     \n";
        assert_eq!(address_space_limit_bytes(unlimited), None);
    }

    #[test]
    fn this_process_can_allocate_something() {
        // Linux only: elsewhere /proc does not tell and nothing is checked.
        if cfg!(target_os = "linux") {
            let available = process_memory_available_bytes().expect("/proc is readable");
            assert!(available > 0);
        }
    }
}
