//! Composition of WGSL sources: each pass's shader is its own file preceded
//! by the shared libraries it needs. The layer is deliberately thin: plain
//! concatenation in a fixed order, so that naga's error positions map back to
//! files through the `// ---- file:` markers.

/// A named WGSL source file.
#[derive(Clone, Copy, Debug)]
pub struct WgslFile {
    /// File name, for diagnostics.
    pub name: &'static str,
    /// Its text.
    pub source: &'static str,
}

/// Concatenates the given files into one shader module source.
pub fn compose(files: &[WgslFile]) -> String {
    let mut out = String::new();
    for file in files {
        out.push_str("// ---- file: ");
        out.push_str(file.name);
        out.push('\n');
        out.push_str(file.source);
        out.push('\n');
    }
    out
}

/// Shared declarations: constants, the frame uniform and its binding.
pub const COMMON: WgslFile = WgslFile {
    name: "shaders/common.wgsl",
    source: include_str!("shaders/common.wgsl"),
};
/// A full-screen triangle vertex shader.
pub const FULLSCREEN: WgslFile = WgslFile {
    name: "shaders/fullscreen.wgsl",
    source: include_str!("shaders/fullscreen.wgsl"),
};
/// Lambertian surfaces lit by the sun and the environment, `lambert_radiance`
/// (needs `COMMON`, the atmosphere lookups and the stratus lookup); shared by
/// the terrain and the static objects.
pub const LAMBERT: WgslFile = WgslFile {
    name: "shaders/lambert.wgsl",
    source: include_str!("shaders/lambert.wgsl"),
};
/// Shading of open water (needs `COMMON` and the atmosphere lookups).
pub const WATER: WgslFile = WgslFile {
    name: "shaders/water.wgsl",
    source: include_str!("shaders/water.wgsl"),
};

/// Every composed shader module of the renderer, by name: what the naga
/// validation test checks.
pub fn all_modules() -> Vec<(&'static str, String)> {
    let mut modules = crate::atmosphere::shader_sources();
    modules.extend([
        ("sky", crate::sky::shader_source()),
        ("terrain", crate::terrain::shader_source()),
        ("objects", crate::objects::shader_source()),
        ("rain simulation", crate::rain::simulation_shader_source()),
        ("rain visibility", crate::rain::visibility_shader_source()),
        ("rain streaks", crate::rain::streaks_shader_source()),
        ("rain mist", crate::rain::mist_shader_source()),
        ("rain shadow map", crate::rain::occluders_shader_source()),
        ("exposure", crate::exposure::shader_source()),
        ("tonemap", crate::tonemap::shader_source()),
        ("radiosity", crate::radiosity::shader_source()),
        ("stratus layer", crate::stratus::layer_shader_source()),
        ("stratus compute", crate::stratus::compute_shader_source()),
        ("cumulus", crate::cumulus::draw_shader_source()),
        ("cumulus shadow", crate::cumulus::shadow_shader_source()),
        (
            "cumulus composite",
            crate::cumulus::composite_shader_source(),
        ),
    ]);
    modules
}

/// The shared files every drawing pass that reads the atmosphere needs, in order.
pub const DRAWING_LIBRARIES: [WgslFile; 4] = [
    COMMON,
    crate::atmosphere::ATMOSPHERE,
    crate::atmosphere::LIGHTING_TYPES,
    crate::atmosphere::LOOKUP,
];

/// Creates a shader module from composed source.
pub fn create_module(device: &wgpu::Device, label: &str, source: &str) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    })
}
