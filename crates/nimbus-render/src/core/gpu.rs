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
    /// record's).
    pub fn new(preference: AdapterPreference) -> Result<Self, GpuError> {
        Self::with_instance(&Self::instance(), preference, None)
    }

    /// A wgpu instance on the backends named by `WGPU_BACKEND`, else the
    /// primary ones (Vulkan, Metal, DX12).
    pub fn instance() -> wgpu::Instance {
        let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        if std::env::var_os("WGPU_BACKEND").is_none() {
            descriptor.backends = wgpu::Backends::PRIMARY;
        }
        wgpu::Instance::new(descriptor)
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
