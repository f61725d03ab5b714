//! Terrain pass: uploads the procedural heightfield (from
//! [`nimbus_physics::terrain`]) as a mesh plus its albedo map, and draws it
//! lit by the sun and sky.
//!
//! The albedo map ([`TerrainPass::albedo_view`]) and the sun's visibility
//! over the terrain are bound at group 1; the clouds' shadows come from the
//! frame's group 3 ([`crate::frame::cloud_lighting`]). The stratus layer's
//! radiosity reads the ground's reflectance from the terrain on the CPU
//! (`RadiosityGrid::ground_reflectance`), and the rain stops on the
//! terrain's triangles ([`TerrainPass::occluder_geometry`]), not on the map.

use crate::core::background::{Deferred, Precompute};
use crate::core::binding;
use crate::core::limits::{self, LimitError};
use crate::core::mesh::IndexedMesh;
use crate::core::pipeline::{DrawPipeline, hdr_target, opaque_depth};
use crate::frame::occluders::OccluderGeometry;
use crate::frame::{FrameBindings, FrameLayouts};
use crate::scene::GroundAlbedoMap;
use crate::shader::{self, WgslFile};
use bytemuck::{Pod, Zeroable};
use nimbus_physics::terrain::{self, Terrain, TerrainParams};
use std::sync::Arc;
use wgpu::util::DeviceExt;

const TERRAIN_WGSL: WgslFile = WgslFile {
    name: "passes/terrain/terrain.wgsl",
    source: include_str!("terrain.wgsl"),
};

/// The composed WGSL of this pass.
pub fn shader_source() -> String {
    shader::compose(&[TERRAIN_WGSL])
}

/// One mesh vertex (WGSL `TerrainVertex`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct TerrainVertex {
    /// World position, m.
    pub position_m: [f32; 3],
    /// Unit surface normal.
    pub normal: [f32; 3],
    /// Albedo-map coordinate (texel centre of the vertex).
    pub uv: [f32; 2],
}

const VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 3] =
    wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2];

// The occluder consumers read the position at the start of each vertex.
const _: () = assert!(std::mem::offset_of!(TerrainVertex, position_m) == 0);

/// Builds the triangle mesh of a terrain: one vertex per grid point, two
/// triangles per cell, counter-clockwise seen from above.
pub fn build_mesh(terrain: &Terrain) -> (Vec<TerrainVertex>, Vec<u32>) {
    let n = terrain.vertices_per_side();
    let mut vertices = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let (x, z) = terrain.vertex_xz_m(i, j);
            let k = j * n + i;
            vertices.push(TerrainVertex {
                position_m: [x as f32, terrain.surface_height_m[k], z as f32],
                normal: terrain.surface_normal[k],
                uv: [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32],
            });
        }
    }
    let indices = grid_indices(n as u32);
    (vertices, indices)
}

pub use crate::core::mesh::grid_indices;

/// What the terrain pass prepares: the procedural relief, drawn, or a
/// flat ground of one albedo that is not drawn (a caller's world stands on
/// it) but that the stratus radiosity and the ground light read.
#[derive(Clone, Debug, PartialEq)]
pub enum Ground {
    /// The relief of these parameters.
    Relief(TerrainParams),
    /// A flat ground: side length and height, m, and linear albedo.
    Flat {
        /// Side of the square it covers, centred on the origin, m.
        extent_m: f64,
        /// Its height, m.
        height_m: f64,
        /// Its linear albedo.
        albedo: [f32; 3],
        /// Its albedo as a map over the square instead, when given.
        albedo_map: Option<GroundAlbedoMap>,
    },
}

/// Cells per side of a flat ground's grid: it has no relief to resolve,
/// only the radiosity grid's texels to cover.
const FLAT_GROUND_RESOLUTION: u32 = 64;

impl Ground {
    fn generate(&self) -> Terrain {
        match self {
            Ground::Relief(params) => terrain::generate(params),
            Ground::Flat {
                extent_m,
                height_m,
                albedo,
                albedo_map,
            } => match albedo_map {
                Some(map) => terrain::flat_with_albedo_map(
                    *extent_m,
                    FLAT_GROUND_RESOLUTION,
                    *height_m,
                    map.map(),
                ),
                None => terrain::flat(*extent_m, FLAT_GROUND_RESOLUTION, *height_m, *albedo),
            },
        }
    }

    fn resolution(&self) -> u32 {
        match self {
            Ground::Relief(params) => params.resolution,
            Ground::Flat { .. } => FLAT_GROUND_RESOLUTION,
        }
    }

    /// Whether it is drawn and stops the rain.
    pub fn is_drawn(&self) -> bool {
        matches!(self, Ground::Relief(_))
    }
}

/// GPU resources of the terrain for one set of parameters.
#[derive(Debug)]
struct TerrainMesh {
    ground: Ground,
    /// The CPU terrain, kept to recompute the sun visibility when the sun moves.
    terrain: Arc<Terrain>,
    /// Its mean albedo ([`Terrain::mean_albedo`]).
    mean_albedo: [f64; 3],
    triangles: IndexedMesh,
    albedo: wgpu::Texture,
    albedo_view: wgpu::TextureView,
    sun_visibility: wgpu::Texture,
    /// Sun direction the visibility map was computed for.
    sun_direction: Option<[f64; 3]>,
    /// The terrain's shadow in the air for that sun
    /// ([`terrain::sun_shadow_ceiling_m`]), once computed.
    sun_shadow_ceiling: Option<Arc<Vec<f32>>>,
    bind_group: wgpu::BindGroup,
}

/// The terrain pass.
#[derive(Debug)]
pub struct TerrainPass {
    pipeline: wgpu::RenderPipeline,
    group_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    mesh: Option<TerrainMesh>,
    /// Incremented whenever the mesh is rebuilt (the rain redraws its shadow map).
    generation: u64,
    /// The ground generated and meshed (a worker thread's work).
    generated: Deferred<Ground, GeneratedGround>,
    /// The sun-visibility texels and the shadow ceiling of (mesh
    /// generation, sun direction).
    sun_visibility: Deferred<(u64, [f64; 3]), SunShadows>,
    /// Incremented whenever a new shadow ceiling is ready (the renderer
    /// hands it to the frame's cloud lighting).
    shadow_ceiling_generation: u64,
}

/// The terrain's shadows for one sun: on its surface (R8 visibility per
/// vertex) and in the air above it (the shadow ceiling).
#[derive(Debug)]
struct SunShadows {
    visibility: Vec<u8>,
    ceiling: Arc<Vec<f32>>,
}

/// A ground generated and meshed on the CPU, ready to upload.
#[derive(Debug)]
struct GeneratedGround {
    terrain: Arc<Terrain>,
    vertices: Vec<TerrainVertex>,
    indices: Vec<u32>,
    albedo_texels: Vec<[u8; 4]>,
}

impl GeneratedGround {
    fn of(ground: &Ground) -> Self {
        let terrain = ground.generate();
        let (vertices, indices) = build_mesh(&terrain);
        let albedo_texels = terrain.albedo_rgba8();
        Self {
            terrain: Arc::new(terrain),
            vertices,
            indices,
            albedo_texels,
        }
    }
}

/// The sun's visibility over the terrain as R8 texels.
fn sun_visibility_texels(terrain: &Terrain, sun_direction: [f64; 3]) -> Vec<u8> {
    terrain::sun_visibility(terrain, sun_direction)
        .iter()
        .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
        .collect()
}

impl TerrainPass {
    /// Creates the pipeline; the mesh is built by [`Self::prepare`].
    pub fn new(device: &wgpu::Device, frame: &FrameLayouts<'_>) -> Self {
        let group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("terrain albedo"),
            entries: &[
                binding::texture_2d_entry(0, true),
                binding::filtering_sampler_entry(1),
                binding::texture_2d_entry(2, true),
            ],
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("terrain albedo"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let module = shader::create_module(device, "terrain", &shader_source());
        let layout = frame.pipeline_layout(device, "terrain", Some(&group_layout));
        let pipeline = DrawPipeline {
            label: "terrain",
            layout: &layout,
            module: &module,
            vertex_entry: "terrain_vertex",
            fragment_entry: Some("terrain_fragment"),
            vertex_buffers: &[wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<TerrainVertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &VERTEX_ATTRIBUTES,
            }],
            cull_mode: Some(wgpu::Face::Back),
            depth: Some(opaque_depth()),
            targets: &hdr_target(None),
        }
        .create(device);
        Self {
            pipeline,
            group_layout,
            sampler,
            mesh: None,
            generation: 0,
            generated: Deferred::new("terrain"),
            sun_visibility: Deferred::new("terrain sun visibility"),
            shadow_ceiling_generation: 0,
        }
    }

    /// Generates the terrain when its parameters changed (on a worker
    /// thread under [`Precompute::Background`]: until it is ready nothing is
    /// drawn) and uploads it once generated.
    ///
    /// The mesh's buffer sizes are checked against the device's limit first.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        ground: &Ground,
        precompute: Precompute,
    ) -> Result<(), LimitError> {
        if self.mesh.as_ref().is_some_and(|m| &m.ground == ground) {
            return Ok(());
        }
        let side = ground.resolution() as u64 + 1;
        let what = format!("terrain.resolution = {}", ground.resolution());
        let vertex_bytes = side * side * std::mem::size_of::<TerrainVertex>() as u64;
        limits::check_buffer_size(device, &what, vertex_bytes)?;
        limits::check_buffer_size(device, &what, (side - 1) * (side - 1) * 6 * 4)?;
        let Some((built_ground, built)) =
            self.generated.request(ground.clone(), precompute, || {
                let job = ground.clone();
                move || GeneratedGround::of(&job)
            })
        else {
            return Ok(());
        };
        if self
            .mesh
            .as_ref()
            .is_some_and(|m| &m.ground == built_ground)
        {
            return Ok(());
        }
        let terrain = built.terrain.clone();
        let mesh = IndexedMesh::upload(device, "terrain", &built.vertices, &built.indices);
        let side = terrain.vertices_per_side() as u32;
        let albedo = device.create_texture_with_data(
            queue,
            &wgpu::TextureDescriptor {
                label: Some("terrain albedo"),
                size: wgpu::Extent3d {
                    width: side,
                    height: side,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba8UnormSrgb,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            bytemuck::cast_slice(&built.albedo_texels),
        );
        let albedo_view = albedo.create_view(&Default::default());
        let sun_visibility = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("terrain sun visibility"),
            size: wgpu::Extent3d {
                width: side,
                height: side,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R8Unorm,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let sun_visibility_view = sun_visibility.create_view(&Default::default());
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("terrain albedo"),
            layout: &self.group_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&albedo_view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Sampler(&self.sampler),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&sun_visibility_view),
                },
            ],
        });
        self.generation += 1;
        self.mesh = Some(TerrainMesh {
            ground: built_ground.clone(),
            mean_albedo: terrain.mean_albedo(),
            terrain,
            triangles: mesh,
            albedo,
            albedo_view,
            sun_visibility,
            sun_direction: None,
            sun_shadow_ceiling: None,
            bind_group,
        });
        Ok(())
    }

    /// Recomputes the sun-visibility map (terrain shadows) when the sun has
    /// moved or the terrain was regenerated (on a worker thread under
    /// [`Precompute::Background`]: the previous map stays until the new one
    /// is ready, and the terrain is not drawn before its first). Call after
    /// [`Self::prepare`].
    pub fn prepare_sun(
        &mut self,
        queue: &wgpu::Queue,
        sun_direction: [f64; 3],
        precompute: Precompute,
    ) {
        let Some(mesh) = &mut self.mesh else { return };
        if mesh.sun_direction == Some(sun_direction) {
            return;
        }
        let key = (self.generation, sun_direction);
        let Some(((generation, direction), shadows)) =
            self.sun_visibility.request(key, precompute, || {
                let terrain = mesh.terrain.clone();
                move || SunShadows {
                    visibility: sun_visibility_texels(&terrain, sun_direction),
                    ceiling: Arc::new(terrain::sun_shadow_ceiling_m(&terrain, sun_direction)),
                }
            })
        else {
            return;
        };
        if *generation != self.generation || mesh.sun_direction == Some(*direction) {
            return;
        }
        let side = mesh.terrain.vertices_per_side() as u32;
        queue.write_texture(
            mesh.sun_visibility.as_image_copy(),
            &shadows.visibility,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(side),
                rows_per_image: Some(side),
            },
            wgpu::Extent3d {
                width: side,
                height: side,
                depth_or_array_layers: 1,
            },
        );
        mesh.sun_direction = Some(*direction);
        mesh.sun_shadow_ceiling = Some(shadows.ceiling.clone());
        self.shadow_ceiling_generation += 1;
    }

    /// The terrain's shadow in the air for the sun of the last
    /// [`Self::prepare_sun`] ([`terrain::sun_shadow_ceiling_m`]: heights, m,
    /// over [`terrain::SHADOW_CEILING_TEXELS`]² texels of the terrain's
    /// square), half the square's side, m, and a number that changes
    /// whenever the ceiling does; `None` until the first is ready.
    pub fn sun_shadow_ceiling(&self) -> Option<(&[f32], f64, u64)> {
        let mesh = self.mesh.as_ref()?;
        let ceiling = mesh.sun_shadow_ceiling.as_ref()?;
        Some((
            ceiling.as_slice(),
            0.5 * mesh.terrain.params.extent_m,
            self.shadow_ceiling_generation,
        ))
    }

    /// The work under way on a worker thread, if any.
    pub fn pending(&self) -> impl Iterator<Item = &'static str> {
        [self.generated.pending(), self.sun_visibility.pending()]
            .into_iter()
            .flatten()
    }

    /// Blocks until the work under way has finished (the next
    /// [`Self::prepare`] uploads it).
    pub fn wait(&mut self) {
        self.generated.wait();
        self.sun_visibility.wait();
    }

    /// The CPU terrain, once prepared.
    pub fn terrain(&self) -> Option<&Terrain> {
        self.mesh.as_ref().map(|m| m.terrain.as_ref())
    }

    /// The mean albedo of the prepared ground (over its vertices, water
    /// included), once prepared: the near ground that lights the clouds
    /// from below ([`crate::frame::atmosphere::ground_albedo`]).
    pub fn mean_albedo(&self) -> Option<[f64; 3]> {
        self.mesh.as_ref().map(|m| m.mean_albedo)
    }

    /// The albedo map (RGB albedo, A water mask), once prepared.
    pub fn albedo_view(&self) -> Option<&wgpu::TextureView> {
        self.mesh.as_ref().map(|m| &m.albedo_view)
    }

    /// The albedo texture, once prepared.
    pub fn albedo_texture(&self) -> Option<&wgpu::Texture> {
        self.mesh.as_ref().map(|m| &m.albedo)
    }

    /// Counts the mesh's rebuilds.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// The terrain's triangles for occlusion maps (world position at offset
    /// 0 of each vertex, `u32` indices), once prepared.
    pub fn occluder_geometry(&self) -> Option<OccluderGeometry<'_>> {
        self.mesh
            .as_ref()
            .filter(|m| m.ground.is_drawn())
            .map(|m| OccluderGeometry::of_mesh::<TerrainVertex>(&m.triangles))
    }

    /// Records the draw into `pass`.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, frame: &FrameBindings<'_>) {
        // Not before its first sun visibility: an unwritten map is all shadow.
        let Some(mesh) = self
            .mesh
            .as_ref()
            .filter(|m| m.ground.is_drawn() && m.sun_direction.is_some())
        else {
            return;
        };
        pass.set_pipeline(&self.pipeline);
        frame.set_on(pass, Some(&mesh.bind_group));
        mesh.triangles.draw(pass);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mesh_triangles_face_up() {
        let t = terrain::generate(&TerrainParams {
            resolution: 16,
            height_scale_m: 0.0,
            ..TerrainParams::default()
        });
        let (v, idx) = build_mesh(&t);
        assert_eq!(idx.len(), 16 * 16 * 6);
        for tri in idx.chunks(3) {
            let p = |k: u32| glam::Vec3::from_array(v[k as usize].position_m);
            let normal = (p(tri[1]) - p(tri[0])).cross(p(tri[2]) - p(tri[0]));
            assert!(normal.y > 0.0, "triangle {tri:?} faces down");
        }
    }
}
