//! Objects pass: the scene's static objects (`[[objects]]`: boxes and glTF
//! meshes), baked into one world-space vertex and index buffer, drawn after
//! the terrain and lit exactly as it is (`shader/lit_surface.wgsl`).
//!
//! The geometry is rebuilt only when `scene.objects` (or the directory
//! their paths resolve against) changes, or a file read for it is
//! rewritten (its [`crate::scene::FileStamp`]); [`ObjectsPass::generation`] counts
//! the rebuilds so that consumers of [`ObjectsPass::occluder_geometry`]
//! (the rain's occlusion map) know when to redraw. The pass has no group 1:
//! the cloud shadow map and the layer's lighting come from the frame's
//! group 3, as for the terrain.

pub use crate::scene::gltf as gltf_mesh;
pub use crate::scene::object_geometry as geometry;

pub use geometry::{ObjectGeometry, ObjectVertex, ObjectsError};
pub use gltf_mesh::{GltfError, GltfMesh, load_gltf};

use crate::core::limits;
use crate::core::mesh::IndexedMesh;
use crate::core::pipeline::{DrawPipeline, hdr_target, opaque_depth};
use crate::frame::occluders::OccluderGeometry;
use crate::frame::{FrameBindings, FrameLayouts};
use crate::scene::{FileStamp, Scene, SceneObject};
use crate::shader::{self, WgslFile};
use std::path::PathBuf;

const OBJECTS_WGSL: WgslFile = WgslFile {
    name: "passes/objects/objects.wgsl",
    source: include_str!("objects.wgsl"),
};

/// The composed WGSL of this pass.
pub fn shader_source() -> String {
    shader::compose(&[OBJECTS_WGSL])
}

const VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 3] =
    wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x3];

// The occluder consumers read the position at the start of each vertex.
const _: () = assert!(std::mem::offset_of!(ObjectVertex, position_m) == 0);

/// The objects' buffers on the GPU.
#[derive(Debug)]
struct GpuGeometry {
    mesh: IndexedMesh,
    bounds_m: ([f32; 3], [f32; 3]),
}

/// What the current geometry was built from.
#[derive(Debug, PartialEq)]
struct BuiltFrom {
    objects: Vec<SceneObject>,
    base_dir: Option<PathBuf>,
    /// The files read, as they were then.
    files: Vec<(PathBuf, Option<FileStamp>)>,
}

impl BuiltFrom {
    /// Whether `scene`'s objects are these, from the same files unchanged.
    fn matches(&self, scene: &Scene) -> bool {
        self.objects == scene.objects
            && self.base_dir == scene.base_dir
            && self
                .files
                .iter()
                .all(|(path, stamp)| FileStamp::of(path) == *stamp)
    }
}

/// The objects pass.
#[derive(Debug)]
pub struct ObjectsPass {
    pipeline: wgpu::RenderPipeline,
    built_from: Option<BuiltFrom>,
    geometry: Option<GpuGeometry>,
    generation: u64,
}

impl ObjectsPass {
    /// Creates the pipeline; the geometry is built by [`Self::prepare`].
    pub fn new(device: &wgpu::Device, frame: &FrameLayouts<'_>) -> Self {
        let module = shader::create_module(device, "objects", &shader_source());
        // No group 1: the objects need only the frame's groups.
        let layout = frame.pipeline_layout(device, "objects", None);
        let pipeline = DrawPipeline {
            label: "objects",
            layout: &layout,
            module: &module,
            vertex_entry: "objects_vertex",
            fragment_entry: Some("objects_fragment"),
            vertex_buffers: &[wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<ObjectVertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &VERTEX_ATTRIBUTES,
            }],
            // No culling: glTF meshes need not be closed (a roof may be one
            // sheet); the fragment shader lights back faces as the side seen.
            cull_mode: None,
            depth: Some(opaque_depth()),
            targets: &hdr_target(None),
        }
        .create(device);
        Self {
            pipeline,
            built_from: None,
            geometry: None,
            generation: 0,
        }
    }

    /// Rebuilds and uploads the objects' geometry when `scene.objects`
    /// changed (reading their glTF files again), after checking the buffer
    /// sizes against the device's limit. On failure the pass draws nothing
    /// until a later prepare succeeds.
    pub fn prepare(&mut self, device: &wgpu::Device, scene: &Scene) -> Result<(), ObjectsError> {
        let unchanged = self.built_from.as_ref().is_some_and(|b| b.matches(scene));
        if unchanged {
            return Ok(());
        }
        // The old buffers go first: on failure nothing stale is drawn.
        self.built_from = None;
        if self.geometry.take().is_some() {
            self.generation += 1;
        }
        let geometry = geometry::build(scene)?;
        if let Some(bounds_m) = geometry.bounds_m() {
            let what = format!("objects ({} triangles)", geometry.triangle_count());
            let vertex_bytes = std::mem::size_of_val(geometry.vertices.as_slice()) as u64;
            let index_bytes = std::mem::size_of_val(geometry.indices.as_slice()) as u64;
            limits::check_buffer_size(device, &what, vertex_bytes)?;
            limits::check_buffer_size(device, &what, index_bytes)?;
            self.geometry = Some(GpuGeometry {
                mesh: IndexedMesh::upload(device, "objects", &geometry.vertices, &geometry.indices),
                bounds_m,
            });
            // Counted once per rebuild that has geometry, once more when
            // buffers were dropped above: any change of the buffers shows.
            self.generation += 1;
        }
        self.built_from = Some(BuiltFrom {
            objects: scene.objects.clone(),
            base_dir: scene.base_dir.clone(),
            files: geometry
                .files_read
                .iter()
                .map(|f| (f.clone(), FileStamp::of(f)))
                .collect(),
        });
        Ok(())
    }

    /// Whether there is anything to draw.
    pub fn enabled(&self) -> bool {
        self.geometry.is_some()
    }

    /// The objects' triangles for occlusion maps (world position at offset
    /// 0 of each vertex, `u32` indices); `None` without objects.
    pub fn occluder_geometry(&self) -> Option<OccluderGeometry<'_>> {
        self.geometry
            .as_ref()
            .map(|g| OccluderGeometry::of_mesh::<ObjectVertex>(&g.mesh))
    }

    /// Axis-aligned bounds (min, max) of all objects, world m; `None` without objects.
    pub fn world_bounds_m(&self) -> Option<([f32; 3], [f32; 3])> {
        self.geometry.as_ref().map(|g| g.bounds_m)
    }

    /// Counts the rebuilds of the geometry: changes whenever the buffers of
    /// [`Self::occluder_geometry`] (or their absence) change.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Records the draw into `pass` (nothing without objects).
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, frame: &FrameBindings<'_>) {
        let Some(geometry) = &self.geometry else {
            return;
        };
        pass.set_pipeline(&self.pipeline);
        frame.set_on(pass, None);
        geometry.mesh.draw(pass);
    }
}
