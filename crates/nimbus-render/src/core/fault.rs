//! GPU faults as typed errors: a lost device, memory the device could not
//! allocate, and the errors wgpu raises on a device. wgpu reports these
//! through callbacks (its default handler of errors panics); the devices
//! nimbus creates record them here instead ([`DeviceFaults`]), and the work
//! of a frame is wrapped in error scopes ([`FaultScope`]), so that a
//! headless render stops with a [`GpuFault`] at its next check — after each
//! submission and read-back — before anything is written.

use std::sync::{Arc, Mutex};

/// What the device's uncaptured errors were caught doing: they happen
/// outside the error scopes of nimbus's frames and read-backs (e.g. a
/// caller's own work on the device).
const UNSCOPED_WORK: &str = "running work outside nimbus's checked frames";

/// A fault of the GPU device.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum GpuFault {
    /// The device was lost (a driver reset, the GPU removed, the device
    /// destroyed): nothing more can be drawn on it.
    #[error("the GPU device was lost ({reason}){}", detail(message))]
    Lost {
        /// wgpu's reason (`destroyed`, or `unknown` for a driver's loss).
        reason: String,
        /// The driver's message, if any.
        message: String,
    },
    /// The device could not allocate a resource.
    #[error(
        "the GPU ran out of memory while {what} (try a smaller image or scene, or a GPU with more memory)"
    )]
    OutOfMemory {
        /// What was being done, with the sizes that matter (e.g. "rendering
        /// a 8192×8192 frame").
        what: String,
    },
    /// wgpu refused an operation (a validation or internal error).
    #[error("the GPU refused an operation while {what}: {message}")]
    Refused {
        /// What was being done.
        what: String,
        /// wgpu's message, on one line.
        message: String,
    },
}

/// ": MESSAGE" when there is one.
fn detail(message: &str) -> String {
    if message.is_empty() {
        String::new()
    } else {
        format!(": {message}")
    }
}

/// wgpu's multi-line message ("Validation Error\n\nCaused by:\n  In …") on
/// one line, without its heading.
fn one_line(message: &str) -> String {
    let line = message.split_whitespace().collect::<Vec<_>>().join(" ");
    line.strip_prefix("Validation Error Caused by: ")
        .map(str::to_owned)
        .unwrap_or(line)
}

impl GpuFault {
    /// The fault of a wgpu error met while doing `what`.
    pub fn from_error(error: &wgpu::Error, what: &str) -> Self {
        match error {
            wgpu::Error::OutOfMemory { .. } => Self::OutOfMemory {
                what: what.to_owned(),
            },
            wgpu::Error::Validation { description, .. }
            | wgpu::Error::Internal { description, .. } => Self::Refused {
                what: what.to_owned(),
                message: one_line(description),
            },
        }
    }
}

/// What a device's callbacks recorded.
#[derive(Debug, Default)]
struct Recorded {
    /// The loss, once the lost callback has run.
    lost: Option<GpuFault>,
    /// The first error raised outside an error scope.
    uncaptured: Option<GpuFault>,
}

/// The faults of one device, recorded by the callbacks that
/// [`DeviceFaults::install`] puts on it; clones share the record.
#[derive(Clone, Debug, Default)]
pub struct DeviceFaults {
    recorded: Arc<Mutex<Recorded>>,
}

impl DeviceFaults {
    /// Installs on `device` a handler of uncaptured errors that records the
    /// first one instead of panicking (wgpu's default), and a device-lost
    /// callback that records the loss.
    pub fn install(device: &wgpu::Device) -> Self {
        let faults = Self::default();
        let sink = faults.clone();
        device.on_uncaptured_error(Arc::new(move |error: wgpu::Error| {
            sink.record(|r| {
                r.uncaptured
                    .get_or_insert_with(|| GpuFault::from_error(&error, UNSCOPED_WORK));
            });
        }));
        let sink = faults.clone();
        device.set_device_lost_callback(move |reason, message| {
            let reason = match reason {
                wgpu::DeviceLostReason::Destroyed => "destroyed",
                wgpu::DeviceLostReason::Unknown => "unknown",
            };
            sink.record(|r| {
                r.lost.get_or_insert_with(|| GpuFault::Lost {
                    reason: reason.to_owned(),
                    message: one_line(&message),
                });
            });
        });
        faults
    }

    fn record(&self, f: impl FnOnce(&mut Recorded)) {
        // A callback that panicked while holding the lock left a record that
        // is still valid (each field is set whole).
        f(&mut self.recorded.lock().unwrap_or_else(|e| e.into_inner()));
    }

    /// The recorded fault, if any: the loss first (errors that follow a
    /// loss are its consequences), then the first uncaptured error. Faults
    /// stay recorded: a lost device stays lost, and a resource that failed
    /// to be created stays invalid.
    pub fn check(&self) -> Result<(), GpuFault> {
        let recorded = self.recorded.lock().unwrap_or_else(|e| e.into_inner());
        match recorded.lost.as_ref().or(recorded.uncaptured.as_ref()) {
            Some(fault) => Err(fault.clone()),
            None => Ok(()),
        }
    }
}

/// Error scopes catching the out-of-memory and validation errors of the
/// calls on one device made by this thread between [`FaultScope::push`]
/// and [`FaultScope::pop`] (dropped unpopped, it discards them).
#[must_use = "pop the scope to learn its errors"]
pub struct FaultScope {
    // Popped in the reverse order of pushing: fields drop in declaration
    // order, so the one pushed last comes first.
    validation: wgpu::ErrorScopeGuard,
    out_of_memory: wgpu::ErrorScopeGuard,
}

impl FaultScope {
    /// Pushes the scopes.
    pub fn push(device: &wgpu::Device) -> Self {
        let out_of_memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        Self {
            validation,
            out_of_memory,
        }
    }

    /// Pops the scopes and returns what they caught, named by `what`; out
    /// of memory first (the validation errors that follow, on the resources
    /// that could not be created, are its consequences).
    pub fn pop(self, what: &str) -> Result<(), GpuFault> {
        let Self {
            validation,
            out_of_memory,
        } = self;
        // wgpu-core's futures are ready at once.
        let validation = pollster::block_on(validation.pop());
        let out_of_memory = pollster::block_on(out_of_memory.pop());
        match out_of_memory.or(validation) {
            Some(error) => Err(GpuFault::from_error(&error, what)),
            None => Ok(()),
        }
    }
}

/// Waits for the work submitted to `device`. wgpu's `Device::poll` (29)
/// panics when the driver reports the device lost (or out of memory) while
/// waiting: its backend treats that as fatal, after its core has marked the
/// device lost and called the lost callback. That panic is caught here and
/// returned as an error, so that the caller reports the recorded loss
/// ([`DeviceFaults::check`]) instead of crashing. (Rust's panic hook has
/// printed wgpu's message by then.)
pub fn wait_for_device(device: &wgpu::Device) -> Result<(), String> {
    let poll = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        device.poll(wgpu::PollType::wait_indefinitely())
    }));
    match poll {
        Ok(Ok(_)) => Ok(()),
        Ok(Err(e)) => Err(e.to_string()),
        Err(panic) => Err(panic
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| panic.downcast_ref::<&str>().map(|s| (*s).to_owned()))
            .map_or_else(
                || "waiting for the GPU failed".to_owned(),
                |message| one_line(&message),
            )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wgpu_messages_read_on_one_line_without_their_heading() {
        let message = "Validation Error\n\nCaused by:\n  In Device::create_texture, label = 'hdr'\n    Dimension X is zero\n";
        assert_eq!(
            one_line(message),
            "In Device::create_texture, label = 'hdr' Dimension X is zero"
        );
    }

    #[test]
    fn a_loss_names_its_reason_and_the_drivers_message_if_any() {
        let lost = |reason: &str, message: &str| GpuFault::Lost {
            reason: reason.to_owned(),
            message: message.to_owned(),
        };
        assert_eq!(
            lost("destroyed", "").to_string(),
            "the GPU device was lost (destroyed)"
        );
        assert_eq!(
            lost("unknown", "Device is lost").to_string(),
            "the GPU device was lost (unknown): Device is lost"
        );
    }
}
