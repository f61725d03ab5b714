//! Adapter and device creation for headless use (the CLI, tests, benchmarks).
//!
//! An embedding application creates its own device and passes it to
//! `Renderer::new`; this module is the convenience path for
//! programs that have none, including machines without a GPU, where Mesa's
//! software Vulkan driver (lavapipe) provides a CPU adapter.

use super::fault::DeviceFaults;
use std::fmt;

/// Which kind of adapter to use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AdapterPreference {
    /// A hardware GPU if there is one, otherwise a software adapter.
    #[default]
    Auto,
    /// Only a hardware GPU (integrated, discrete or virtual).
    Hardware,
    /// Only a software (CPU) adapter such as lavapipe.
    Software,
}

impl std::str::FromStr for AdapterPreference {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "auto" => Ok(Self::Auto),
            "hardware" => Ok(Self::Hardware),
            "software" => Ok(Self::Software),
            other => Err(format!(
                "adapter `{other}`: must be one of auto, hardware, software"
            )),
        }
    }
}

impl fmt::Display for AdapterPreference {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Auto => "auto",
            Self::Hardware => "hardware",
            Self::Software => "software",
        })
    }
}

/// The window systems' Vulkan surface extensions on Unix desktops. A
/// headless instance leaves them out: with any of them enabled, Mesa's
/// device-selection layer (installed with its drivers, software Vulkan
/// included) connects to the display server to choose a default device,
/// and without one libwayland prints `error: XDG_RUNTIME_DIR is invalid or
/// not set in the environment.` on standard error at each enumeration.
#[cfg(all(
    unix,
    not(target_os = "macos"),
    not(target_os = "ios"),
    not(target_os = "android")
))]
const WINDOW_SYSTEM_EXTENSIONS: [&std::ffi::CStr; 3] = [
    c"VK_KHR_wayland_surface",
    c"VK_KHR_xcb_surface",
    c"VK_KHR_xlib_surface",
];

/// A Vulkan-only instance without [`WINDOW_SYSTEM_EXTENSIONS`], for
/// drawing offscreen; `None` where Vulkan cannot be loaded (the caller then
/// makes wgpu's usual instance, which reports the missing driver).
#[cfg(all(
    unix,
    not(target_os = "macos"),
    not(target_os = "ios"),
    not(target_os = "android")
))]
#[allow(unsafe_code)]
fn headless_vulkan_instance(descriptor: &wgpu::InstanceDescriptor) -> Option<wgpu::Instance> {
    use wgpu::hal;
    let hal_descriptor = hal::InstanceDescriptor {
        name: "nimbus",
        flags: descriptor.flags,
        memory_budget_thresholds: descriptor.memory_budget_thresholds,
        backend_options: descriptor.backend_options.clone(),
        telemetry: None,
        display: None,
    };
    let leave_out_window_systems: Box<hal::vulkan::CreateInstanceCallback<'_>> = Box::new(|args| {
        args.extensions
            .retain(|name| !WINDOW_SYSTEM_EXTENSIONS.contains(name));
    });
    // SAFETY: `init_with_callback` asks that the callback remove no
    // feature wgpu relies on. The three extensions removed serve only
    // `create_surface_from_{wayland,xcb,xlib}`, which check the instance's
    // enabled extensions first and return an error when one is missing;
    // nimbus never creates a surface on this instance (it draws offscreen;
    // the viewer makes its own instance with a display).
    let instance = unsafe {
        hal::vulkan::Instance::init_with_callback(&hal_descriptor, Some(leave_out_window_systems))
    }
    .ok()?;
    // SAFETY: a valid Vulkan instance, made just above and handed over
    // whole: wgpu owns and destroys it.
    Some(unsafe { wgpu::Instance::from_hal::<hal::api::Vulkan>(instance) })
}

/// Elsewhere, the platform's window systems do not open connections when an
/// instance is made: wgpu's usual instance.
#[cfg(not(all(
    unix,
    not(target_os = "macos"),
    not(target_os = "ios"),
    not(target_os = "android")
)))]
fn headless_vulkan_instance(_descriptor: &wgpu::InstanceDescriptor) -> Option<wgpu::Instance> {
    None
}

/// What to install when no adapter is found.
pub const NO_ADAPTER_HELP: &str = "install a Vulkan driver; without a GPU use software Vulkan (Debian/Ubuntu: apt-get install mesa-vulkan-drivers)";

/// Why a GPU context could not be created.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter of the requested kind.
    #[error("no {preference} GPU adapter found (adapters seen: {seen}); {help}", help = NO_ADAPTER_HELP)]
    NoAdapter {
        /// The requested kind.
        preference: AdapterPreference,
        /// Names of the adapters that were found, if any.
        seen: String,
    },
    /// The adapter refused to create a device.
    #[error("cannot create a device on adapter `{adapter}`: {message}")]
    Device {
        /// The adapter's name.
        adapter: String,
        /// wgpu's message.
        message: String,
    },
}

/// A device, its queue and a description of its adapter.
#[derive(Clone, Debug)]
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter's description.
    pub adapter_info: wgpu::AdapterInfo,
    /// The adapter.
    pub adapter: wgpu::Adapter,
    /// The device's loss and the errors it raised outside error scopes,
    /// recorded instead of wgpu's default handler's panic.
    pub faults: DeviceFaults,
}

fn is_software(info: &wgpu::AdapterInfo) -> bool {
    info.device_type == wgpu::DeviceType::Cpu
}

fn rank(info: &wgpu::AdapterInfo) -> u8 {
    match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

impl GpuContext {
    /// Picks an adapter by preference (backends from `WGPU_BACKEND`, else the
    /// primary ones: Vulkan, Metal, DX12) and creates a device with timestamp
    /// queries where the adapter supports them. The device's uncaptured
    /// errors and its loss are recorded in [`Self::faults`] instead of
    /// panicking (an uncaptured-error handler installed later replaces the
    /// record's). The instance is [`Self::headless_instance`]'s: no
    /// display server is asked.
    pub fn new(preference: AdapterPreference) -> Result<Self, GpuError> {
        Self::with_instance(&Self::headless_instance(), preference, None)
    }

    /// A wgpu instance on the backends named by `WGPU_BACKEND`, else the
    /// primary ones (Vulkan, Metal, DX12), that can present to windows.
    pub fn instance() -> wgpu::Instance {
        wgpu::Instance::new(Self::instance_descriptor())
    }

    /// A wgpu instance for drawing offscreen, on the same backends as
    /// [`Self::instance`]. Where that is Vulkan on a Unix desktop, it
    /// enables no window system's surface extension (with one, Mesa's
    /// device-selection layer asks the display server for its device, and
    /// prints errors where there is none), so that opening it touches no
    /// display server.
    pub fn headless_instance() -> wgpu::Instance {
        let descriptor = Self::instance_descriptor();
        if std::env::var_os("WGPU_BACKEND").is_none()
            && let Some(instance) = headless_vulkan_instance(&descriptor)
        {
            return instance;
        }
        wgpu::Instance::new(descriptor)
    }

    fn instance_descriptor() -> wgpu::InstanceDescriptor {
        let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        if std::env::var_os("WGPU_BACKEND").is_none() {
            descriptor.backends = wgpu::Backends::PRIMARY;
        }
        descriptor
    }

    /// Like [`Self::new`] on the caller's instance, with an adapter that can
    /// present to `surface` when one is given (a window's).
    pub fn with_instance(
        instance: &wgpu::Instance,
        preference: AdapterPreference,
        surface: Option<&wgpu::Surface<'_>>,
    ) -> Result<Self, GpuError> {
        let mut adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
        let seen = adapters
            .iter()
            .map(|a| a.get_info().name)
            .collect::<Vec<_>>()
            .join(", ");
        adapters.retain(|a| match preference {
            AdapterPreference::Auto => true,
            AdapterPreference::Hardware => !is_software(&a.get_info()),
            AdapterPreference::Software => is_software(&a.get_info()),
        });
        let of_preferred_kind = adapters.len();
        if let Some(surface) = surface {
            adapters.retain(|a| a.is_surface_supported(surface));
        }
        // Stable order: device type, then name, so that the choice is repeatable.
        adapters.sort_by_key(|a| {
            let info = a.get_info();
            (rank(&info), info.name)
        });
        let adapter = adapters
            .into_iter()
            .next()
            .ok_or_else(|| GpuError::NoAdapter {
                preference,
                seen: if seen.is_empty() {
                    "none".to_owned()
                } else if of_preferred_kind > 0 {
                    format!("{seen}; none of them can draw to the window")
                } else {
                    seen
                },
            })?;
        let adapter_info = adapter.get_info();
        let wanted =
            wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS;
        let required_features = adapter.features() & wanted;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("nimbus device"),
            required_features,
            // Large textures and buffers as far as the adapter allows; the
            // renderer checks image and mesh sizes against these before allocating.
            required_limits: wgpu::Limits {
                max_buffer_size: adapter.limits().max_buffer_size,
                // Millions of rain drops: as many per storage buffer as the
                // adapter binds, so that they need few buffers (the rain
                // splits them over several where one does not hold them).
                max_storage_buffer_binding_size: adapter.limits().max_storage_buffer_binding_size,
                ..wgpu::Limits::default().using_resolution(adapter.limits())
            },
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| GpuError::Device {
            adapter: adapter_info.name.clone(),
            message: e.to_string(),
        })?;
        let faults = DeviceFaults::install(&device);
        Ok(Self {
            device,
            queue,
            adapter_info,
            adapter,
            faults,
        })
    }

    /// A one-line description: name, backend and device type.
    pub fn adapter_summary(&self) -> String {
        format!(
            "{} ({:?}, {:?})",
            self.adapter_info.name, self.adapter_info.backend, self.adapter_info.device_type
        )
    }
}
