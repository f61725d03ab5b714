//! Bevy's meshes stop nimbus's rain.
//!
//! Every entity with a `Mesh3d` of triangles (and no [`NoRainOcclusion`])
//! gives its world-space triangles to nimbus
//! ([`nimbus_render::Renderer::set_occluders`]): the drops that reach them
//! splash there and none falls beneath (nimbus's rain shadow map). The
//! triangles are gathered again when a mesh entity is added, moved or
//! removed, or its mesh asset changes; in a world of many moving meshes,
//! give the static ones the rain's attention and mark the rest
//! [`NoRainOcclusion`].

use bevy::asset::{AssetEvent, Assets};
use bevy::ecs::prelude::*;
use bevy::log::warn;
use bevy::mesh::{Mesh, Mesh3d, PrimitiveTopology};

use bevy::transform::components::GlobalTransform;

/// Leaves a mesh out of the rain's occluders (rain falls through it).
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct NoRainOcclusion;

/// The triangles that stop the rain, world space, metres: gathered from
/// Bevy's meshes, handed to nimbus when `generation` changes.
#[derive(Resource, Clone, Debug, Default)]
pub struct NimbusOccluders {
    /// Vertex positions.
    pub positions_m: Vec<[f32; 3]>,
    /// A triangle list of indices into `positions_m`.
    pub indices: Vec<u32>,
    /// Counts the changes.
    pub generation: u64,
}

/// Largest number of occluder triangles gathered from Bevy's meshes: past
/// it the rest are left out, with a warning.
pub const MAX_OCCLUDER_TRIANGLES: usize = 4_000_000;

type MeshQuery<'w, 's> =
    Query<'w, 's, (Entity, &'static Mesh3d, &'static GlobalTransform), Without<NoRainOcclusion>>;

/// Mesh entities moved, re-meshed or newly left out.
type ChangedQuery<'w, 's> = Query<
    'w,
    's,
    (),
    (
        With<Mesh3d>,
        Or<(
            Changed<GlobalTransform>,
            Changed<Mesh3d>,
            Added<NoRainOcclusion>,
        )>,
    ),
>;

/// Gathers the meshes' triangles when something changed.
#[allow(clippy::too_many_arguments)]
pub(crate) fn gather_occluders(
    meshes: MeshQuery,
    changed: ChangedQuery,
    mut removed_meshes: RemovedComponents<Mesh3d>,
    mut removed_opt_out: RemovedComponents<NoRainOcclusion>,
    mut asset_events: MessageReader<AssetEvent<Mesh>>,
    assets: Res<Assets<Mesh>>,
    mut occluders: ResMut<NimbusOccluders>,
    mut incomplete: Local<bool>,
) {
    let removed = removed_meshes.read().count() + removed_opt_out.read().count() > 0;
    let assets_changed = asset_events.read().count() > 0;
    if changed.is_empty() && !removed && !assets_changed && !*incomplete {
        return;
    }
    let mut positions_m = Vec::new();
    let mut indices = Vec::new();
    *incomplete = false;
    let mut warned = false;
    for (entity, mesh, transform) in &meshes {
        let Some(mesh) = assets.get(&mesh.0) else {
            // Not loaded yet: gather again next frame.
            *incomplete = true;
            continue;
        };
        if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
            continue;
        }
        let Ok(attribute) = mesh.try_attribute(Mesh::ATTRIBUTE_POSITION) else {
            continue;
        };
        let Some(local) = attribute.as_float3() else {
            continue;
        };
        let first = positions_m.len() as u32;
        let triangle_count = match mesh.try_indices() {
            Ok(mesh_indices) => mesh_indices.len() / 3,
            Err(_) => local.len() / 3,
        };
        if indices.len() / 3 + triangle_count > MAX_OCCLUDER_TRIANGLES {
            if !warned {
                warn!(
                    "nimbus: rain occluders: more than {MAX_OCCLUDER_TRIANGLES} triangles; \
                     mesh {entity} and later ones are left out (mark meshes NoRainOcclusion)"
                );
                warned = true;
            }
            continue;
        }
        positions_m.extend(
            local
                .iter()
                .map(|p| transform.transform_point((*p).into()).to_array()),
        );
        match mesh.try_indices() {
            Ok(mesh_indices) => {
                if mesh_indices.iter().any(|i| i >= local.len()) {
                    warn!(
                        "nimbus: rain occluders: mesh {entity} has an index past its {} vertices; left out",
                        local.len()
                    );
                    positions_m.truncate(first as usize);
                    continue;
                }
                let whole = mesh_indices.len() / 3 * 3;
                indices.extend(mesh_indices.iter().take(whole).map(|i| first + i as u32));
            }
            Err(_) => indices.extend((0..(local.len() / 3 * 3) as u32).map(|i| first + i)),
        }
    }
    occluders.positions_m = positions_m;
    occluders.indices = indices;
    occluders.generation += 1;
}
