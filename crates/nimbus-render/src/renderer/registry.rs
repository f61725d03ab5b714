//! Every composed shader module of the renderer, by name: what the naga
//! validation test checks and what shader errors are mapped back to files
//! with.

use crate::passes::{
    atmosphere, composite, cumulus, exposure, objects, rain, sky, stratus, terrain, tonemap,
};
use crate::shader;

/// Every composed shader module of the renderer, by name.
pub fn all_modules() -> Vec<(&'static str, String)> {
    let mut modules = atmosphere::shader_sources();
    modules.extend([
        ("sky", sky::shader_source()),
        ("terrain", terrain::shader_source()),
        ("objects", objects::shader_source()),
        ("rain simulation", rain::simulation_shader_source()),
        ("rain visibility", rain::visibility_shader_source()),
        ("rain streaks", rain::streaks_shader_source()),
        ("rain mist", rain::mist_shader_source()),
        ("rain shadow map", rain::occluders_shader_source()),
        ("rain depth occluder", rain::depth_occluder_shader_source()),
        ("exposure", exposure::shader_source()),
        ("tonemap", tonemap::shader_source()),
        ("radiosity", stratus::radiosity::shader_source()),
        ("stratus layer", stratus::layer_shader_source()),
        ("stratus in-layer", stratus::in_layer_shader_source()),
        ("stratus compute", stratus::compute_shader_source()),
        ("cumulus", cumulus::draw_shader_source()),
        ("cumulus shadow", cumulus::shadow_shader_source()),
        ("cumulus composite", cumulus::composite_shader_source()),
        ("cumulus in-cloud", cumulus::in_cloud_shader_source()),
        ("composite", composite::shader_source()),
        ("nimbus lighting include", crate::shader::lighting_include()),
    ]);
    modules
}

/// [`shader::map_positions`] for a message naming one of [`all_modules`]
/// by its label (`label = 'sky'`, as wgpu's validation errors do).
pub fn map_error_positions(message: &str) -> String {
    all_modules()
        .into_iter()
        .find(|(name, _)| message.contains(&format!("label = '{name}'")))
        .map_or_else(
            || message.to_owned(),
            |(_, source)| shader::map_positions(message, &source),
        )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// Every file of every module is found under its name in the checkout
    /// with the embedded text, so that hot reload edits what is rendered.
    #[test]
    fn file_names_resolve_to_the_embedded_files_in_the_checkout() {
        let dir = Path::new(shader::CHECKOUT_SOURCE_DIR);
        let mut checked = 0;
        for (module, source) in all_modules() {
            assert!(!source.contains("unresolved import"), "module {module}");
            for (index, part) in source.split(shader::FILE_MARKER).enumerate().skip(1) {
                let (name, embedded) = part.split_once('\n').expect("marker line");
                let on_disk = std::fs::read_to_string(dir.join(name))
                    .unwrap_or_else(|e| panic!("module {module}, file #{index} {name}: {e}"));
                assert_eq!(
                    embedded.strip_suffix('\n'),
                    Some(on_disk.as_str()),
                    "module {module}: {name}"
                );
                checked += 1;
            }
        }
        assert!(checked > 40, "only {checked} files checked");
    }
}
