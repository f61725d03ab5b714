//! Light transport in cloud layers: phase-function models for tracing, a
//! Monte-Carlo photon tracer for plane-parallel slabs, and the analytic
//! stratiform model of Bouthors, Neyret & Lefebvre (2006, §4 and
//! appendices A–B) that the tracer validates.

pub mod adding_doubling;
pub mod diffusion;
pub mod fit;
pub mod interior_source;
pub mod monte_carlo;
pub mod phase_model;
pub mod reflected_exit;
pub mod rng;
pub mod sky_source;
pub mod stratus;

/// The default droplets as the tables' tests trace them.
#[cfg(test)]
pub(crate) mod test_media {
    use super::monte_carlo::SlabMedium;
    use super::phase_model::PhaseModel;
    use super::stratus::StratusOptics;
    use crate::optics::dsd::{SizeDistribution, bulk_optics};
    use crate::optics::phase::PhaseTable;
    use crate::optics::tables::computation_angles;
    use crate::optics::water::water_refractive_index;

    /// The default droplets' slab (r_e 7 µm, γ 2, 300 cm⁻³, 550 nm) of
    /// `thickness_m` with the forward peak (5°) folded into extinction: P_S
    /// and κ_S, as the analytic model's orders see them.
    pub fn default_droplets_slab(thickness_m: f64) -> SlabMedium {
        let (extinction_per_m, medium) = default_droplets();
        SlabMedium {
            optical_depth: extinction_per_m * thickness_m,
            ..medium
        }
    }

    /// The same droplets' modified extinction (m⁻¹) and a slab of them of
    /// unit optical depth.
    pub fn default_droplets() -> (f64, SlabMedium) {
        let forward_peak_deg = 5.0;
        let dsd = SizeDistribution::ModifiedGamma {
            number_density_per_m3: 300e6,
            gamma: 2.0,
            effective_radius_m: 7e-6,
        };
        let optics = bulk_optics(
            &dsd,
            550.0,
            water_refractive_index(550.0),
            &computation_angles(forward_peak_deg),
            1e-3,
        );
        let phase = PhaseTable::new(optics.angles_deg.clone(), optics.phase.clone());
        let modified = StratusOptics::from_phase(&phase, optics.extinction_per_m, forward_peak_deg)
            .modified_extinction_per_m();
        (
            modified,
            SlabMedium {
                optical_depth: 1.0,
                single_scattering_albedo: optics.single_scattering_albedo(),
                phase: PhaseModel::tabulated(&phase.peak_removed(forward_peak_deg)),
            },
        )
    }
}
