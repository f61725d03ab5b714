//! The passes of a frame by name: timer slots, run flags and the names
//! timings are reported under.

/// A pass of the frame, in the order passes run (the discriminant is its
/// timer slot and its place in [`PASS_NAMES`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PassId {
    /// Atmosphere: transmittance LUT.
    Transmittance,
    /// Atmosphere: multiple-scattering LUT.
    MultipleScattering,
    /// Atmosphere: sky-view LUT.
    SkyView,
    /// Atmosphere: aerial-perspective volume.
    AerialPerspective,
    /// Atmosphere: lighting inputs (sun, sky, ground, environment SH).
    Lighting,
    /// The stratus layer's thickness field and ground–cloud radiosity.
    StratusLighting,
    /// The cumulus shadow map.
    CumulusShadow,
    /// Rain: occlusion map, simulation steps and visibility list.
    RainSimulation,
    /// `LinearHdr`: the caller's depth translated into nimbus's.
    CallerDepth,
    /// Sky, sun and open sea.
    Sky,
    /// `LinearHdr`: the air in front of the caller's surfaces.
    CallerAir,
    /// Terrain.
    Terrain,
    /// Static objects.
    Objects,
    /// Cumulus bodies.
    Cumulus,
    /// Cumulus fringes' order-independent accumulation.
    CumulusFringes,
    /// The stratus layer.
    Stratus,
    /// The cumulus fringes' composite.
    CumulusComposite,
    /// Rain mist beyond the rain box.
    RainMist,
    /// Rain streaks and splashes.
    Rain,
    /// The camera in the stratus layer: the layer marched as a volume.
    StratusInLayer,
    /// The camera in a cumulus: the light inside the cloud it is in.
    CumulusInCloudLight,
    /// The camera in a cumulus: the cloud marched as a volume.
    CumulusInCloud,
    /// Exposure metering.
    Exposure,
    /// Tone mapping into the output.
    Tonemap,
    /// `LinearHdr`: nimbus's target composited over the caller's colour.
    Export,
}

impl PassId {
    /// Every pass, in frame order.
    pub const ALL: [PassId; 25] = [
        PassId::Transmittance,
        PassId::MultipleScattering,
        PassId::SkyView,
        PassId::AerialPerspective,
        PassId::Lighting,
        PassId::StratusLighting,
        PassId::CumulusShadow,
        PassId::RainSimulation,
        PassId::CallerDepth,
        PassId::Sky,
        PassId::CallerAir,
        PassId::Terrain,
        PassId::Objects,
        PassId::Cumulus,
        PassId::CumulusFringes,
        PassId::Stratus,
        PassId::CumulusComposite,
        PassId::RainMist,
        PassId::Rain,
        PassId::StratusInLayer,
        PassId::CumulusInCloudLight,
        PassId::CumulusInCloud,
        PassId::Exposure,
        PassId::Tonemap,
        PassId::Export,
    ];

    /// The atmosphere's passes, in the order its encode step reports them.
    pub const ATMOSPHERE: [PassId; 5] = [
        PassId::Transmittance,
        PassId::MultipleScattering,
        PassId::SkyView,
        PassId::AerialPerspective,
        PassId::Lighting,
    ];

    /// The name timings report.
    pub const fn name(self) -> &'static str {
        match self {
            PassId::Transmittance => "transmittance",
            PassId::MultipleScattering => "multiple_scattering",
            PassId::SkyView => "sky_view",
            PassId::AerialPerspective => "aerial_perspective",
            PassId::Lighting => "lighting",
            PassId::StratusLighting => "stratus_lighting",
            PassId::CumulusShadow => "cumulus_shadow",
            PassId::RainSimulation => "rain_simulation",
            PassId::CallerDepth => "caller_depth",
            PassId::Sky => "sky",
            PassId::CallerAir => "caller_air",
            PassId::Terrain => "terrain",
            PassId::Objects => "objects",
            PassId::Cumulus => "cumulus",
            PassId::CumulusFringes => "cumulus_fringes",
            PassId::Stratus => "stratus",
            PassId::CumulusComposite => "cumulus_composite",
            PassId::RainMist => "rain_mist",
            PassId::Rain => "rain",
            PassId::StratusInLayer => "stratus_in_layer",
            PassId::CumulusInCloudLight => "cumulus_in_cloud_light",
            PassId::CumulusInCloud => "cumulus_in_cloud",
            PassId::Exposure => "exposure",
            PassId::Tonemap => "tonemap",
            PassId::Export => "export",
        }
    }

    /// Whether the pass runs only in `OutputMode::LinearHdr` (the caller's
    /// frame: depth import, air over its surfaces, export).
    pub const fn only_in_linear_hdr(self) -> bool {
        matches!(
            self,
            PassId::CallerDepth | PassId::CallerAir | PassId::Export
        )
    }

    /// The pass's timestamp slot.
    pub const fn timer_index(self) -> u32 {
        self as u32
    }
}

/// Names of the passes in frame order, as reported by timings.
pub const PASS_NAMES: [&str; 25] = {
    let mut names = [""; 25];
    let mut i = 0;
    while i < names.len() {
        names[i] = PassId::ALL[i].name();
        i += 1;
    }
    names
};

/// A set of passes (which a frame ran).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PassSet(u32);

impl PassSet {
    /// Every pass.
    pub const fn all() -> Self {
        PassSet((1 << PassId::ALL.len()) - 1)
    }

    /// The set of the given bits ([`Self::bits`]).
    pub const fn from_bits(bits: u32) -> Self {
        PassSet(bits & Self::all().0)
    }

    /// One bit per pass, at its [`PassId::timer_index`].
    pub const fn bits(self) -> u32 {
        self.0
    }

    /// Takes a pass out.
    pub fn remove(&mut self, id: PassId) {
        self.0 &= !(1 << id.timer_index());
    }

    /// Whether the set holds a pass.
    pub const fn contains(self, id: PassId) -> bool {
        self.0 & (1 << id.timer_index()) != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The discriminants follow the frame order, so that timer slots,
    /// names and run flags agree.
    #[test]
    fn ids_are_in_frame_order_with_unique_names() {
        for (i, id) in PassId::ALL.into_iter().enumerate() {
            assert_eq!(id.timer_index() as usize, i);
            assert_eq!(PASS_NAMES[i], id.name());
        }
        let mut names = PASS_NAMES.to_vec();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), PASS_NAMES.len());
        assert_eq!(
            PassId::ATMOSPHERE.map(PassId::name),
            crate::passes::atmosphere::PASS_NAMES
        );
        let mut set = PassSet::all();
        set.remove(PassId::Rain);
        assert!(!set.contains(PassId::Rain) && set.contains(PassId::Tonemap));
        assert_eq!(PassSet::from_bits(set.bits()), set);
    }
}
