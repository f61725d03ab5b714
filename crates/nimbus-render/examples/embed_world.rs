//! nimbus inside your own renderer: your world, your camera, your HDR target
//! and tone mapping; nimbus adds the sky, the clouds, the rain and the air.
//!
//! The program draws a ground plane, a few boxes and a shelter's roof with
//! its own pipeline, lit by nimbus's sun and sky through nimbus's WGSL
//! include (so the boxes receive the clouds' shadows), into its own
//! `Rgba16Float` target and depth buffer (standard depth, finite far plane).
//! nimbus, in `OutputMode::LinearHdr`, composites linear radiance over it
//! by depth; the roof and boxes stop the rain (`Renderer::set_occluders`).
//! Then the program tone maps its target itself. Run with
//! `cargo run --release -p nimbus-render --example embed_world -- [out.png]`;
//! `--width PX --height PX` set the size (960×540 by default), `--timings
//! FRAMES` measures nimbus's passes over that many frames, `--json FILE|-`
//! writes the measurement in the shape of `nimbus bench --json` (the GPU
//! benchmark kit, `tools/gpu-bench/`, runs it so), `--adapter
//! auto|hardware|software` picks the adapter; `--help` says more.

use glam::{DVec3, Mat4};
use nimbus_render::frame::FrameResources;
use nimbus_render::{
    DepthConvention, FrameTargets, Projection, Renderer, RendererDescriptor, Scene, TargetLoad,
    View,
};
use wgpu::util::DeviceExt;

/// The scene nimbus draws around the program's world: no terrain of its
/// own (the program's ground stands in for it, albedo given for the cloud
/// layer's radiosity), cumulus under a broken layer, steady rain.
pub const WORLD_SCENE: &str = r#"
[sun]
azimuth_deg = 200.0
elevation_deg = 30.0

[ground]
terrain = false
albedo = [0.10, 0.12, 0.07]

[stratus]
base_m = 1600.0
thickness_m = 300.0
coverage = 0.45
feature_size_m = 3000.0
seed = 5

[cumulus]
coverage = 0.25
base_m = 600.0
seed = 11

[wind]
speed_m_s = 6.0
from_deg = 250.0

[rain]
intensity_mm_h = 4.0
"#;

/// The program's colour format (nimbus composites into it).
const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// The program's depth format; standard depth, 1 at its far plane.
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// What the program's tone mapping writes.
const DISPLAY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// The program's vertex: world position, normal, linear albedo.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct WorldVertex {
    position_m: [f32; 3],
    normal: [f32; 3],
    albedo: [f32; 3],
}

/// The program's world: a 4 km ground plane, three boxes and a roof
/// (6 m × 4 m, 3 m up, on no posts: the rain under it is what it stops).
fn world_geometry() -> (Vec<WorldVertex>, Vec<u32>) {
    let mut vertices = Vec::new();
    let mut indices = Vec::new();
    let mut quad = |corners: [[f32; 3]; 4], normal: [f32; 3], albedo: [f32; 3]| {
        let first = vertices.len() as u32;
        vertices.extend(corners.map(|position_m| WorldVertex {
            position_m,
            normal,
            albedo,
        }));
        indices.extend([0, 1, 2, 0, 2, 3].map(|i| first + i));
    };
    let ground = 2000.0;
    quad(
        [
            [-ground, 0.0, ground],
            [ground, 0.0, ground],
            [ground, 0.0, -ground],
            [-ground, 0.0, -ground],
        ],
        [0.0, 1.0, 0.0],
        [0.10, 0.12, 0.07],
    );
    let boxes = [
        ([-8.0, 0.0, -10.0], [4.0, 6.0, 4.0], [0.55, 0.52, 0.48]),
        ([6.0, 0.0, -20.0], [5.0, 10.0, 5.0], [0.45, 0.20, 0.15]),
        ([20.0, 0.0, -45.0], [8.0, 14.0, 8.0], [0.60, 0.60, 0.62]),
    ];
    for (min, size, albedo) in boxes {
        let [x0, y0, z0] = min;
        let [x1, y1, z1] = [x0 + size[0], y0 + size[1], z0 + size[2]];
        quad(
            [[x0, y1, z1], [x1, y1, z1], [x1, y1, z0], [x0, y1, z0]],
            [0.0, 1.0, 0.0],
            albedo,
        );
        quad(
            [[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]],
            [0.0, 0.0, 1.0],
            albedo,
        );
        quad(
            [[x1, y0, z0], [x0, y0, z0], [x0, y1, z0], [x1, y1, z0]],
            [0.0, 0.0, -1.0],
            albedo,
        );
        quad(
            [[x1, y0, z1], [x1, y0, z0], [x1, y1, z0], [x1, y1, z1]],
            [1.0, 0.0, 0.0],
            albedo,
        );
        quad(
            [[x0, y0, z0], [x0, y0, z1], [x0, y1, z1], [x0, y1, z0]],
            [-1.0, 0.0, 0.0],
            albedo,
        );
    }
    // The roof, both faces lit as the one seen (the shader flips the normal).
    quad(
        [
            [-14.0, 3.0, 6.0],
            [-8.0, 3.0, 6.0],
            [-8.0, 3.0, 2.0],
            [-14.0, 3.0, 2.0],
        ],
        [0.0, 1.0, 0.0],
        [0.30, 0.25, 0.22],
    );
    (vertices, indices)
}

/// The program's camera: standing 2 m up, looking at the boxes.
pub fn world_view(width: u32, height: u32) -> View {
    View {
        world_from_view: glam::DMat4::look_at_rh(
            DVec3::new(-4.0, 2.0, 22.0),
            DVec3::new(4.0, 6.0, -20.0),
            DVec3::Y,
        )
        .inverse(),
        projection: Projection::Perspective {
            fov_y_rad: 65f64.to_radians(),
            aspect: f64::from(width) / f64::from(height),
            near_m: 0.1,
            far_m: Some(20_000.0),
        },
        depth: DepthConvention::Standard,
    }
}

/// The program's own shader: nimbus's lighting include, then its world
/// (group 1: its camera) and its tone mapping.
fn world_shader() -> String {
    nimbus_render::shader::lighting_include()
        + r#"
@group(1) @binding(0) var<uniform> program_clip_from_world: mat4x4<f32>;

struct WorldIn {
    @location(0) position_m: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec3<f32>,
}

struct WorldOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) position_m: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec3<f32>,
}

@vertex
fn world_vertex(v: WorldIn) -> WorldOut {
    var out: WorldOut;
    out.clip = program_clip_from_world * vec4<f32>(v.position_m, 1.0);
    out.position_m = v.position_m;
    out.normal = v.normal;
    out.albedo = v.albedo;
    return out;
}

@fragment
fn world_fragment(in: WorldOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    let n = select(-1.0, 1.0, front) * normalize(in.normal);
    // Linear radiance, pre-exposed as nimbus's own output is.
    let radiance = nimbus_lambert_radiance(in.albedo, in.position_m, n) * nimbus_pre_exposure();
    return vec4<f32>(radiance, 1.0);
}
"#
}

const TONEMAP_WGSL: &str = r#"
@group(0) @binding(0) var hdr: texture_2d<f32>;

@vertex
fn fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

// The program's tone mapping: Reinhard on each channel (the display
// target's format does the sRGB encoding).
@fragment
fn tonemap(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let c = textureLoad(hdr, vec2<i32>(p.xy), 0).rgb;
    return vec4<f32>(c / (1.0 + c), 1.0);
}
"#;

fn texture(
    device: &wgpu::Device,
    format: wgpu::TextureFormat,
    width: u32,
    height: u32,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
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
}

/// The program's pipelines and its world on the GPU.
struct Program {
    world: wgpu::RenderPipeline,
    camera: wgpu::Buffer,
    camera_group: wgpu::BindGroup,
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    tonemap: wgpu::RenderPipeline,
    tonemap_layout: wgpu::BindGroupLayout,
}

impl Program {
    fn new(device: &wgpu::Device, nimbus: &FrameResources) -> Self {
        let (vertices, indices) = world_geometry();
        let camera = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("program camera"),
            size: 64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let camera_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("program camera"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let camera_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("program camera"),
            layout: &camera_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: camera.as_entire_binding(),
            }],
        });
        // nimbus's groups 0, 2, 3 around the program's group 1.
        let layout =
            nimbus
                .layouts()
                .pipeline_layout(device, "program world", Some(&camera_layout));
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("program world"),
            source: wgpu::ShaderSource::Wgsl(world_shader().into()),
        });
        let world = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("program world"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("world_vertex"),
                compilation_options: Default::default(),
                buffers: &[wgpu::VertexBufferLayout {
                    array_stride: std::mem::size_of::<WorldVertex>() as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x3],
                }],
            },
            primitive: Default::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("world_fragment"),
                compilation_options: Default::default(),
                targets: &[Some(HDR_FORMAT.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        let tonemap_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("program tone mapping"),
            source: wgpu::ShaderSource::Wgsl(TONEMAP_WGSL.into()),
        });
        let tonemap = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("program tone mapping"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &tonemap_module,
                entry_point: Some("fullscreen"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &tonemap_module,
                entry_point: Some("tonemap"),
                compilation_options: Default::default(),
                targets: &[Some(DISPLAY_FORMAT.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        let tonemap_layout = tonemap.get_bind_group_layout(0);
        Self {
            world,
            camera,
            camera_group,
            vertices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("program world"),
                contents: bytemuck::cast_slice(&vertices),
                usage: wgpu::BufferUsages::VERTEX,
            }),
            indices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("program world"),
                contents: bytemuck::cast_slice(&indices),
                usage: wgpu::BufferUsages::INDEX,
            }),
            index_count: indices.len() as u32,
            tonemap,
            tonemap_layout,
        }
    }
}

/// The last rendered frame: the tone-mapped RGBA8 (sRGB) pixels and the
/// linear radiance (RGBA, W·sr⁻¹·m⁻², the pre-exposure undone), row-major;
/// with timestamps, each frame's GPU time per nimbus pass, ms, in
/// `PASS_NAMES` order (`None`: not run that frame); and each frame's wall
/// and CPU times.
pub struct WorldFrame {
    /// Tone-mapped pixels, RGBA8 sRGB.
    pub pixels: Vec<u8>,
    /// Linear radiance, RGBA.
    pub radiance: Vec<[f32; 4]>,
    /// Per frame, nimbus's pass times, ms (empty without timestamps).
    pub pass_times_ms: Vec<Vec<Option<f64>>>,
    /// Per frame, the times the program measured around nimbus's calls.
    pub frame_times: Vec<FrameTimes>,
    /// Rain drops simulated and drawn in the last frame (`None` without rain).
    pub rain_drops: Option<u32>,
}

/// One frame's times, ms.
#[derive(Clone, Copy, Debug)]
pub struct FrameTimes {
    /// Wall clock from the frame's submission to the device's completion of
    /// it (the program's world and tone mapping included).
    pub wall_ms: f64,
    /// CPU time of `Renderer::prepare_view`.
    pub prepare_ms: f64,
    /// CPU time of nimbus's `encode_lighting` and `encode` calls.
    pub encode_ms: f64,
}

/// Renders `frames` frames of the program's world with nimbus's sky, clouds
/// and rain, the last at `time_s` (1/30 s apart), tone mapped; with nimbus's
/// per-pass GPU times when `timestamps` and the device has them.
#[allow(clippy::too_many_arguments)]
pub fn render_world(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    scene: &Scene,
    width: u32,
    height: u32,
    time_s: f32,
    frames: u32,
    timestamps: bool,
) -> Result<WorldFrame, Box<dyn std::error::Error>> {
    // The size against the device's limits before anything is allocated.
    Renderer::check_size(device, width, height)?;
    // 1. nimbus, compositing linear radiance into the program's HDR target.
    let mut renderer = Renderer::new(
        device,
        queue,
        &RendererDescriptor::linear_hdr(HDR_FORMAT).with_timestamps(timestamps),
    );
    // The program's exposure (EV100 14, a bright overcast day), shared with nimbus.
    let pre_exposure = 683.0 / (1.2 * 2f32.powi(14));
    renderer.set_pre_exposure(pre_exposure);
    // The program's world stops the rain.
    let (vertices, indices) = world_geometry();
    let positions: Vec<[f32; 3]> = vertices.iter().map(|v| v.position_m).collect();
    renderer.set_occluders(&positions, &indices)?;
    let program = Program::new(device, renderer.frame_resources());
    let view = world_view(width, height);
    let clip_from_world = (view.caller_clip_from_view() * view.view_from_world()).as_mat4();
    queue.write_buffer(
        &program.camera,
        0,
        bytemuck::cast_slice(&Mat4::to_cols_array(&clip_from_world)),
    );

    // 2. The program's targets: its HDR colour and depth (nimbus reads the
    // depth, so TEXTURE_BINDING), and its display target.
    let hdr = texture(
        device,
        HDR_FORMAT,
        width,
        height,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
    );
    let depth = texture(
        device,
        DEPTH_FORMAT,
        width,
        height,
        wgpu::TextureUsages::TEXTURE_BINDING,
    );
    let display = texture(
        device,
        DISPLAY_FORMAT,
        width,
        height,
        wgpu::TextureUsages::COPY_SRC,
    );
    let (hdr_view, depth_view, display_view) = (
        hdr.create_view(&Default::default()),
        depth.create_view(&Default::default()),
        display.create_view(&Default::default()),
    );

    // 3. Prepare: the rain runs from a few seconds before the frame so that
    // the drops have filled the rain box; the shapes and tables are made
    // on worker threads, waited for here (a render loop would not wait).
    let frames = frames.max(1);
    let first_s = time_s - (frames - 1) as f32 / 30.0;
    for t in [first_s - 2.0, first_s - 1.0, first_s] {
        renderer.prepare_view(scene, &view, width, height, t)?;
        while !renderer.is_ready() {
            renderer.wait_for_precompute();
            renderer.prepare_view(scene, &view, width, height, t)?;
        }
        if t < first_s {
            let mut encoder = device.create_command_encoder(&Default::default());
            renderer.encode_lighting(&mut encoder);
            queue.submit([encoder.finish()]);
        }
    }

    // 4. The frame: nimbus's lighting (shadows, rain), the program's world
    // lit through the include, nimbus over it, the program's tone mapping.
    // Each frame is waited for, so that its wall time is its own (as
    // `nimbus bench` measures); the last one is then read back.
    let mut pass_times_ms = Vec::new();
    let mut frame_times = Vec::new();
    for frame in 0..frames {
        let t = first_s + frame as f32 / 30.0;
        let prepare_start = std::time::Instant::now();
        renderer.prepare_view(scene, &view, width, height, t)?;
        let prepare_ms = prepare_start.elapsed().as_secs_f64() * 1e3;
        let mut encoder = device.create_command_encoder(&Default::default());
        let lighting_start = std::time::Instant::now();
        renderer.encode_lighting(&mut encoder);
        let mut encode_ms = lighting_start.elapsed().as_secs_f64() * 1e3;
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("program world"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &hdr_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&program.world);
            renderer
                .frame_resources()
                .bindings()
                .set_on(&mut pass, Some(&program.camera_group));
            pass.set_vertex_buffer(0, program.vertices.slice(..));
            pass.set_index_buffer(program.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..program.index_count, 0, 0..1);
        }
        let encode_start = std::time::Instant::now();
        renderer.encode(
            &mut encoder,
            &FrameTargets {
                output: &hdr_view,
                depth: &depth_view,
                load: TargetLoad::Keep,
            },
        );
        encode_ms += encode_start.elapsed().as_secs_f64() * 1e3;
        {
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("program tone mapping"),
                layout: &program.tonemap_layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&hdr_view),
                }],
            });
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("program tone mapping"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &display_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&program.tonemap);
            pass.set_bind_group(0, &group, &[]);
            pass.draw(0..3, 0..1);
        }
        let commands = encoder.finish();
        let submitted = std::time::Instant::now();
        queue.submit([commands]);
        device.poll(wgpu::PollType::wait_indefinitely())?;
        frame_times.push(FrameTimes {
            wall_ms: submitted.elapsed().as_secs_f64() * 1e3,
            prepare_ms,
            encode_ms,
        });
        if let Some(times) = renderer.read_pass_times_ms() {
            pass_times_ms.push(times);
        }
    }
    let display_pixels = read_back(
        device,
        queue,
        device.create_command_encoder(&Default::default()),
        &display,
        4,
    )?;
    let radiance = read_back(
        device,
        queue,
        device.create_command_encoder(&Default::default()),
        &hdr,
        8,
    )?;
    let radiance = bytemuck::cast_slice::<u8, half::f16>(&radiance)
        .chunks(4)
        .map(|c| [0, 1, 2, 3].map(|k| c[k].to_f32() / pre_exposure))
        .collect();
    let rain_drops = {
        let rain = renderer.rain();
        rain.enabled().then(|| rain.dispatched_drops())
    };
    Ok(WorldFrame {
        pixels: display_pixels,
        radiance,
        pass_times_ms,
        frame_times,
        rain_drops,
    })
}

/// Copies `texture` out after the work in `encoder`; rows unpadded.
fn read_back(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mut encoder: wgpu::CommandEncoder,
    texture: &wgpu::Texture,
    bytes_per_pixel: u32,
) -> Result<Vec<u8>, Box<dyn std::error::Error>> {
    let (width, height) = (texture.width(), texture.height());
    let row = width * bytes_per_pixel;
    let padded_row =
        row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("program readback"),
        size: u64::from(padded_row * height),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded_row),
                rows_per_image: None,
            },
        },
        texture.size(),
    );
    queue.submit([encoder.finish()]);
    buffer.map_async(wgpu::MapMode::Read, .., |_| {});
    device.poll(wgpu::PollType::wait_indefinitely())?;
    let pixels = buffer
        .get_mapped_range(..)
        .chunks(padded_row as usize)
        .flat_map(|r| r[..row as usize].to_vec())
        .collect();
    Ok(pixels)
}

#[allow(dead_code)] // The golden test includes this file and calls `render_world`.
fn main() -> std::process::ExitCode {
    use std::process::ExitCode;
    let options = match command_line::Options::parse(std::env::args().skip(1)) {
        Ok(command_line::Parsed::Run(options)) => options,
        Ok(command_line::Parsed::Help) => {
            use std::io::Write as _;
            // A closed pipe (`--help | head`) is not an error.
            let _ = writeln!(std::io::stdout(), "{}", command_line::USAGE);
            return ExitCode::SUCCESS;
        }
        Err(message) => {
            eprintln!(
                "embed_world: error: {message} (usage: {})",
                command_line::SYNOPSIS
            );
            return ExitCode::from(2);
        }
    };
    match command_line::run(&options) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            let message = error.to_string();
            eprintln!(
                "embed_world: error: {}",
                message.lines().collect::<Vec<_>>().join(" ")
            );
            ExitCode::FAILURE
        }
    }
}

/// The program's command line, its run and its timing report (only `main`
/// uses them; the golden test includes this file for `render_world`).
#[allow(dead_code)]
mod command_line {
    use super::{Scene, WORLD_SCENE, render_world};
    use nimbus_render::{AdapterPreference, GpuContext, PASS_NAMES};
    use serde::Serialize;
    use std::path::{Path, PathBuf};

    /// The command line in one line, for error messages.
    pub const SYNOPSIS: &str = "embed_world [OUT.png] [--width PX] [--height PX] [--timings FRAMES] [--adapter auto|hardware|software] [--json FILE|-]";

    /// `--help`.
    pub const USAGE: &str = "\
nimbus in a program's own frame: its world, camera and tone mapping, nimbus's
sky, clouds and rain composited in LinearHdr; writes a PNG.

Usage: embed_world [OUT.png] [--width PX] [--height PX] [--timings FRAMES]
                   [--adapter auto|hardware|software] [--json FILE|-]

  OUT.png            the tone-mapped image (default embed_world.png)
  --width PX         image width, 1 to 16384 (default 960)
  --height PX        image height, 1 to 16384 (default 540)
  --timings FRAMES   render FRAMES measured frames (1 to 100000) after one
                     warm-up frame; nimbus's per-pass GPU medians on stderr
  --adapter KIND     auto (default: a GPU, else software), hardware, software
  --json FILE|-      the timings as one JSON document, in the shape of
                     `nimbus bench --json` (adapter, size, per-pass median
                     and p95, GPU total, wall and CPU times); `-` for standard
                     output (the `wrote` line then goes to standard error);
                     60 frames unless --timings is given";

    /// Largest `--timings`.
    const MAX_FRAMES: u32 = 100_000;
    /// Measured frames of `--json` without `--timings` (`nimbus bench`'s default).
    const DEFAULT_JSON_FRAMES: u32 = 60;

    /// What the command line asked for.
    #[derive(Debug)]
    pub struct Options {
        output: PathBuf,
        width: u32,
        height: u32,
        /// Measured frames (after one warm-up), when timing.
        timings: Option<u32>,
        adapter: AdapterPreference,
        /// Where the JSON report goes (`-`: standard output).
        json: Option<String>,
    }

    /// A parsed command line.
    #[derive(Debug)]
    pub enum Parsed {
        /// Render with these options.
        Run(Options),
        /// `--help`: print the usage.
        Help,
    }

    fn value(flag: &str, args: &mut impl Iterator<Item = String>) -> Result<String, String> {
        args.next()
            .filter(|v| !v.starts_with("--"))
            .ok_or_else(|| format!("{flag} needs a value"))
    }

    fn number(flag: &str, text: &str, max: u32, what: &str) -> Result<u32, String> {
        text.parse::<u32>()
            .ok()
            .filter(|n| (1..=max).contains(n))
            .ok_or_else(|| {
                format!("{flag} `{text}`: must be a whole number of {what} in [1, {max}]")
            })
    }

    impl Options {
        /// Parses the arguments after the program's name; an error is one line.
        pub fn parse(args: impl IntoIterator<Item = String>) -> Result<Parsed, String> {
            let mut args = args.into_iter();
            let mut output = None;
            let (mut width, mut height) = (960, 540);
            let mut timings = None;
            let mut adapter = AdapterPreference::Auto;
            let mut json = None;
            let max_side = nimbus_render::scene::MAX_IMAGE_SIDE_PX;
            while let Some(arg) = args.next() {
                match arg.as_str() {
                    "-h" | "--help" => return Ok(Parsed::Help),
                    "--width" => {
                        width =
                            number("--width", &value("--width", &mut args)?, max_side, "pixels")?
                    }
                    "--height" => {
                        height = number(
                            "--height",
                            &value("--height", &mut args)?,
                            max_side,
                            "pixels",
                        )?
                    }
                    "--timings" => {
                        timings = Some(number(
                            "--timings",
                            &value("--timings", &mut args)?,
                            MAX_FRAMES,
                            "frames",
                        )?)
                    }
                    "--adapter" => adapter = value("--adapter", &mut args)?.parse()?,
                    "--json" => {
                        // `-` is a value here, not a flag.
                        let file = args.next().filter(|v| v == "-" || !v.starts_with('-'));
                        json =
                            Some(file.ok_or(
                                "--json needs a value (a file, or `-` for standard output)",
                            )?);
                    }
                    flag if flag.starts_with('-') => return Err(format!("unknown flag `{flag}`")),
                    path if output.is_none() => output = Some(PathBuf::from(path)),
                    extra => {
                        return Err(format!(
                            "unexpected argument `{extra}` (one output image only)"
                        ));
                    }
                }
            }
            let output = output.unwrap_or_else(|| PathBuf::from("embed_world.png"));
            let is_png = output
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("png"));
            if !is_png {
                return Err(format!(
                    "output `{}`: must be a .png file",
                    output.display()
                ));
            }
            if json.is_some() && timings.is_none() {
                timings = Some(DEFAULT_JSON_FRAMES);
            }
            Ok(Parsed::Run(Self {
                output,
                width,
                height,
                timings,
                adapter,
                json,
            }))
        }
    }

    /// Median, 95th percentile and largest value of a series, ms (as
    /// `nimbus bench` reports them: nearest-rank percentiles).
    #[derive(Debug, Serialize)]
    struct Stats {
        median_ms: f64,
        p95_ms: f64,
        max_ms: f64,
    }

    impl Stats {
        fn of(values: &[f64]) -> Option<Self> {
            let mut sorted = values.to_vec();
            sorted.sort_by(f64::total_cmp);
            let rank = |p: f64| {
                sorted[((p * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len()) - 1]
            };
            (!sorted.is_empty()).then(|| Self {
                median_ms: rank(0.5),
                p95_ms: rank(0.95),
                max_ms: rank(1.0),
            })
        }
    }

    /// One nimbus pass in the report.
    #[derive(Debug, Serialize)]
    struct PassReport {
        name: &'static str,
        /// Measured frames in which the pass ran.
        frames: usize,
        #[serde(flatten)]
        stats: Option<Stats>,
    }

    /// The `--json` report: `nimbus bench --json`'s fields where they apply.
    #[derive(Debug, Serialize)]
    struct Report {
        scene: &'static str,
        output_mode: &'static str,
        adapter: String,
        backend: String,
        device_type: String,
        driver: String,
        width: u32,
        height: u32,
        frames: u32,
        #[serde(skip_serializing_if = "Option::is_none")]
        rain_drops: Option<u32>,
        timestamps_supported: bool,
        /// nimbus's passes (the program's own world and tone mapping are
        /// not among them).
        passes: Vec<PassReport>,
        gpu_total: Option<Stats>,
        frame_wall: Option<Stats>,
        cpu_prepare: Option<Stats>,
        cpu_encode: Option<Stats>,
        cpu_total: Option<Stats>,
        note: String,
    }

    /// Writes `text` to `path` through a temporary file and a rename.
    fn write_atomically(path: &Path, text: &str) -> Result<(), String> {
        let name = path
            .file_name()
            .ok_or_else(|| format!("--json {}: not a file name", path.display()))?;
        let mut temporary = name.to_owned();
        temporary.push(format!(".{}.tmp", std::process::id()));
        let temporary = path.with_file_name(temporary);
        std::fs::write(&temporary, text)
            .and_then(|()| std::fs::rename(&temporary, path))
            .map_err(|e| {
                let _ = std::fs::remove_file(&temporary);
                format!("--json {}: cannot write: {e}", path.display())
            })
    }

    /// Renders the world and writes the image (and the report).
    pub fn run(options: &Options) -> Result<(), Box<dyn std::error::Error>> {
        let Options {
            output,
            width,
            height,
            timings,
            adapter,
            json,
        } = options;
        let (width, height) = (*width, *height);
        // The outputs' folders exist, before the work.
        let json_path = json.as_deref().filter(|j| *j != "-").map(Path::new);
        for path in std::iter::once(output.as_path()).chain(json_path) {
            let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
            if let Some(dir) = dir.filter(|d| !d.is_dir()) {
                return Err(format!("{}: no folder {}", path.display(), dir.display()).into());
            }
        }
        // A program has its own device; this one takes nimbus's convenience
        // for picking an adapter by kind (timestamp queries where it has them).
        let gpu = GpuContext::new(*adapter)?;
        let scene = Scene::from_toml_str(WORLD_SCENE, "embed_world.toml")?;
        // With --timings, one warm-up frame before the measured ones (the
        // pipelines' first use), as `nimbus bench` does.
        let frames = timings.map_or(1, |n| n + 1);
        let frame = render_world(
            &gpu.device,
            &gpu.queue,
            &scene,
            width,
            height,
            10.0,
            frames,
            timings.is_some(),
        )?;
        gpu.faults.check()?;
        let skip = usize::from(timings.is_some());
        let pass_times = frame.pass_times_ms.get(skip..).unwrap_or_default();
        let frame_times = frame.frame_times.get(skip..).unwrap_or_default();
        let per_pass: Vec<Vec<f64>> = (0..PASS_NAMES.len())
            .map(|i| {
                pass_times
                    .iter()
                    .filter_map(|f| f.get(i).copied().flatten())
                    .collect()
            })
            .collect();
        if timings.is_some() {
            for (name, times) in PASS_NAMES.iter().zip(&per_pass) {
                if let Some(stats) = Stats::of(times) {
                    eprintln!(
                        "{name:<20} median {:8.3} ms over {} frames",
                        stats.median_ms,
                        times.len()
                    );
                }
            }
        }
        if let Some(destination) = json {
            let timestamps = !pass_times.is_empty();
            let totals: Vec<f64> = pass_times
                .iter()
                .map(|f| f.iter().flatten().sum())
                .collect();
            let info = &gpu.adapter_info;
            let series = |f: fn(&super::FrameTimes) -> f64| -> Vec<f64> {
                frame_times.iter().map(f).collect()
            };
            let report = Report {
                scene: "embed_world",
                output_mode: "linear_hdr",
                adapter: info.name.clone(),
                backend: format!("{:?}", info.backend),
                device_type: format!("{:?}", info.device_type),
                driver: format!("{} {}", info.driver, info.driver_info).trim().to_owned(),
                width,
                height,
                frames: timings.unwrap_or(1),
                rain_drops: frame.rain_drops,
                timestamps_supported: timestamps,
                passes: if timestamps {
                    PASS_NAMES
                        .iter()
                        .zip(&per_pass)
                        .map(|(name, times)| PassReport {
                            name,
                            frames: times.len(),
                            stats: Stats::of(times),
                        })
                        .collect()
                } else {
                    Vec::new()
                },
                gpu_total: if timestamps { Stats::of(&totals) } else { None },
                frame_wall: Stats::of(&series(|t| t.wall_ms)),
                cpu_prepare: Stats::of(&series(|t| t.prepare_ms)),
                cpu_encode: Stats::of(&series(|t| t.encode_ms)),
                cpu_total: Stats::of(&series(|t| t.prepare_ms + t.encode_ms)),
                note: "the program's own frame: its world drawn, nimbus composited over it by depth (LinearHdr), its tone mapping; passes are nimbus's, frame_wall the whole frame's".to_owned(),
            };
            let text = serde_json::to_string_pretty(&report)?;
            if destination == "-" {
                print_line(&text)?;
            } else {
                write_atomically(Path::new(destination), &(text + "\n"))?;
            }
        }
        image::save_buffer(
            output,
            &frame.pixels,
            width,
            height,
            image::ExtendedColorType::Rgba8,
        )
        .map_err(|e| format!("{}: cannot write: {e}", output.display()))?;
        if json.as_deref() == Some("-") {
            eprintln!("wrote {}", output.display());
        } else {
            print_line(&format!("wrote {}", output.display()))?;
        }
        Ok(())
    }

    /// A line on standard output; a failed write is an error, not a panic.
    fn print_line(text: &str) -> Result<(), String> {
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), "{text}")
            .map_err(|e| format!("cannot write to standard output: {e}"))
    }
}
