//! GPU faults end a headless render with a typed error, never a panic: a
//! device lost between frames (forced with `Device::destroy`), and errors
//! wgpu raises on the device outside and inside nimbus's error scopes
//! (forced with a buffer wgpu refuses). Out of memory takes the same paths
//! (the scope's other filter, the same record); it is forced for real by
//! the CLI's tests (`nimbus-cli/tests/integration/reliability.rs`), under a bound on
//! the address space of the software adapter.
//!
//! These tests fail, never skip, when no adapter is found; the message says
//! how to install the software driver.

use nimbus_render::fault::FaultScope;
use nimbus_render::headless::{HeadlessError, HeadlessRenderer};
use nimbus_render::{AdapterPreference, GpuFault, Scene};

const WIDTH: u32 = 48;
const HEIGHT: u32 = 32;

fn headless() -> HeadlessRenderer {
    HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"))
}

/// A buffer wgpu refuses: mappable for reading and usable as storage,
/// which needs a feature nimbus does not ask for.
fn refused_buffer(device: &wgpu::Device) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("refused on purpose"),
        size: 256,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    })
}

#[test]
fn a_device_lost_between_frames_ends_the_next_frame_with_the_loss() {
    let mut h = headless();
    let scene = Scene::default();
    h.render_rgba8(&scene, WIDTH, HEIGHT, 0.0)
        .expect("the frame before the loss");
    h.gpu.faults.check().expect("no fault yet");

    h.gpu.device.destroy();
    let err = h
        .render_rgba8(&scene, WIDTH, HEIGHT, 0.0)
        .expect_err("a frame on a lost device");
    match &err {
        HeadlessError::Fault(GpuFault::Lost { reason, .. }) => assert_eq!(reason, "destroyed"),
        other => panic!("expected the loss, got {other:?}"),
    }
    let message = err.to_string();
    assert!(
        message.starts_with("the GPU device was lost (destroyed)"),
        "{message}"
    );
    assert_eq!(message.lines().count(), 1, "{message}");

    // The loss stays: every later frame and read-back reports it, in every
    // output, without touching the device.
    for result in [
        h.render_rgba8(&scene, WIDTH, HEIGHT, 1.0).map(drop),
        h.render_hdr(&scene, WIDTH, HEIGHT, 1.0).map(drop),
        h.render_layers(&scene, WIDTH, HEIGHT, 1.0).map(drop),
        h.exposure_state().map(drop),
    ] {
        assert!(
            matches!(result, Err(HeadlessError::Fault(GpuFault::Lost { .. }))),
            "{result:?}"
        );
    }
    // Dropping the renderer and its resources on the lost device does not panic.
    drop(h);
}

#[test]
fn an_error_outside_the_frames_is_recorded_and_ends_the_next_frame() {
    let mut h = headless();
    // wgpu's default handler would panic here.
    let _buffer = refused_buffer(&h.gpu.device);
    let err = h
        .render_rgba8(&Scene::default(), WIDTH, HEIGHT, 0.0)
        .expect_err("the recorded error");
    match &err {
        HeadlessError::Fault(GpuFault::Refused { message, .. }) => {
            assert!(message.contains("refused on purpose"), "{message}")
        }
        other => panic!("expected the refused buffer, got {other:?}"),
    }
    assert_eq!(err.to_string().lines().count(), 1, "{err}");
}

#[test]
fn an_error_inside_a_scope_is_its_fault_named_by_what_was_done() {
    let h = headless();
    let scope = FaultScope::push(&h.gpu.device);
    let _buffer = refused_buffer(&h.gpu.device);
    let fault = scope
        .pop("creating a test buffer")
        .expect_err("the scope caught the error");
    assert!(
        matches!(&fault, GpuFault::Refused { what, .. } if what == "creating a test buffer"),
        "{fault:?}"
    );
    assert!(
        fault
            .to_string()
            .starts_with("the GPU refused an operation while creating a test buffer: "),
        "{fault}"
    );
    // Caught by the scope, so not left to the device's record.
    h.gpu.faults.check().expect("nothing uncaptured");
}
