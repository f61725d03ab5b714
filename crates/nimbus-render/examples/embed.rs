//! Embedding nimbus in your own wgpu program.
//!
//! The program owns the device, the colour target (here an sRGB texture) and
//! the depth buffer; nimbus draws the sky and terrain into them. Run with
//! `cargo run -p nimbus-render --example embed -- [out.png]`.

use nimbus_render::targets::DEPTH_FORMAT;
use nimbus_render::{FrameTargets, Renderer, RendererDescriptor, Scene, TargetLoad};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let output_path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "embed.png".to_owned());
    let (width, height) = (640u32, 360u32);

    // 1. Your application's device and queue.
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter =
        pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default()))?;
    let (device, queue) =
        pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor::default()))?;

    // 2. Your targets: any colour format, and a Depth32Float buffer (nimbus uses reverse-Z).
    let color_format = wgpu::TextureFormat::Rgba8UnormSrgb;
    let texture = |format, usage| {
        device.create_texture(&wgpu::TextureDescriptor {
            label: None,
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | usage,
            view_formats: &[],
        })
    };
    let color = texture(color_format, wgpu::TextureUsages::COPY_SRC);
    let depth = texture(DEPTH_FORMAT, wgpu::TextureUsages::empty());

    // 3. The nimbus renderer, and a scene (here the embedded default; scenes can be edited every frame).
    let mut renderer = Renderer::new(&device, &queue, &RendererDescriptor::display(color_format));
    let mut scene = Scene::embedded_default();
    scene.sun.azimuth_deg = Some(150.0);
    scene.sun.elevation_deg = Some(35.0);

    // 4. Each frame: prepare, encode, submit. `prepare` never blocks: the
    // cumulus shapes, optics tables and terrain are made on worker threads
    // and frames leave them out until they are ready. A render loop just
    // keeps drawing; this program, which saves one frame, waits for them.
    renderer.prepare(&scene, width, height, 0.0)?;
    while !renderer.is_ready() {
        eprintln!("waiting for {}", renderer.pending_work().join(", "));
        renderer.wait_for_precompute();
        renderer.prepare(&scene, width, height, 0.0)?;
    }
    let mut encoder = device.create_command_encoder(&Default::default());
    let (color_view, depth_view) = (
        color.create_view(&Default::default()),
        depth.create_view(&Default::default()),
    );
    renderer.encode(
        &mut encoder,
        &FrameTargets {
            output: &color_view,
            depth: &depth_view,
            load: TargetLoad::Clear,
        },
    );

    // Read the picture back to save it (an interactive program would present it instead).
    let padded_row = (width * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
        * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: (padded_row * height) as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    encoder.copy_texture_to_buffer(
        color.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &readback,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded_row),
                rows_per_image: None,
            },
        },
        color.size(),
    );
    queue.submit([encoder.finish()]);
    readback.map_async(wgpu::MapMode::Read, .., |result| {
        result.expect("map readback")
    });
    device.poll(wgpu::PollType::wait_indefinitely())?;
    let pixels: Vec<u8> = readback
        .get_mapped_range(..)
        .chunks(padded_row as usize)
        .flat_map(|row| row[..(width * 4) as usize].to_vec())
        .collect();
    image::save_buffer(
        &output_path,
        &pixels,
        width,
        height,
        image::ExtendedColorType::Rgba8,
    )?;
    println!("wrote {output_path}");
    Ok(())
}
