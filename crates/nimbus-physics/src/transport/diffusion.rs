//! The light inside a conservative cloud slab in the diffusion
//! approximation: what a camera inside the stratus layer sees scattered
//! towards it (nimbus-render's `passes/stratus/in_layer.wgsl` is the twin).
//!
//! The slab is taken in the δ-Eddington approximation (Joseph, Wiscombe &
//! Weinman 1976, J. Atmos. Sci. 33, 2452): the droplets' forward peak, a
//! fraction f = g² of the scattering (g the asymmetry), stays in the
//! beam, and the rest scatters with the asymmetry g′ = g/(1 + g). Depths are
//! written in transport optical depth t = (1 − g) κ z (κ the extinction,
//! z the depth below the lit face), total T = (1 − g) κ h, the same for the
//! scaled problem, (1 − g′)(1 − f) = 1 − g. The beam left in the scaled
//! problem decays as e^{−ρ t/μ₀}, ρ = (1 − f)/(1 − g) = 1 + g, its *beam
//! rate*; ρ = 1 is the similarity picture (van de Hulst 1980, §14.6: every
//! forward scattering left in the beam), which keeps about a sixth of the
//! sun's diffuse light in a beam that a camera inside the layer does not
//! see (docs/REALISM.md, "The light inside an overcast").
//!
//! The diffuse fluence Φ (W m⁻², all directions) and net flux F along the
//! depth axis obey the Eddington moment equations for ϖ = 1 (Meador &
//! Weaver 1980, eqs 2–3 written for the fluence): dF/dt = ρ E e^{−ρt/μ₀}
//! (the flux the beam loses), ⅓ dΦ/dt = −F + (ρ − 1) μ₀ E e^{−ρt/μ₀} (Fick's
//! law and the forward part of the beam's first scattering), with
//! Marshak's conditions Φ + 2F = 4 F_in on the top, Φ − 2F = 4 F_in on the
//! base, F_in the diffuse flux entering there. Solutions:
//!
//! - collimated beam of normal irradiance E at cosine μ₀ on the top:
//!   Φ = A + B t − 3 E μ₀² e^{−ρt/μ₀}, F = −B/3 − E μ₀ e^{−ρt/μ₀},
//!   B = −E [3 μ₀² (1 − e) + 2 μ₀ (1 + e)] / (T + 4/3), e = e^{−ρT/μ₀},
//!   A = 3 E μ₀² + 2 E μ₀ + ⅔ B;
//!   its total transmission (F + E μ₀ e^{−ρT/μ₀})/(E μ₀) = (μ₀ + ⅔)/(T + 4/3)
//!   as T grows, the classical diffusion result.
//! - diffuse fluxes F_top, F_base entering the faces (no beam, so ρ plays
//!   no part): Φ = A + B t, F = −B/3, B = 4 (F_base − F_top)/(T + 4/3),
//!   A = 4 F_top + ⅔ B; an isotropic field (F_top = F_base = π L) gives
//!   Φ = 4π L everywhere.
//!
//! The radiance (Eddington's P1, the first two terms of its angular
//! expansion): I(μ) = (Φ + 3 F μ)/(4π), μ the cosine between the light's
//! direction of travel and the depth axis ([`eddington_radiance`]). Looking
//! up into an overcast (the light travelling down the axis, μ = 1) the
//! radiance is above the fluence's isotropic part Φ/(4π), looking down
//! below it.
//!
//! Checked against the slab photon tracer's radiance inside the slab
//! (tests/slab_interior.rs): at the mid-plane of an overcast (τ = 18,
//! μ₀ = 0.64) the similarity picture gives 0.80–0.83 of the traced light
//! travelling down, δ-Eddington 0.94–1.02.
//!
//! Units: t, T dimensionless; E, F in W m⁻², Φ in W m⁻².

/// The δ-Eddington beam rate ρ = (1 − f)/(1 − g) = 1 + g for droplets of
/// asymmetry `asymmetry` (f = g², Joseph et al. 1976): the scaled beam's
/// decay per unit transport optical depth along it.
pub fn delta_eddington_beam_rate(asymmetry: f64) -> f64 {
    1.0 + asymmetry
}

/// Diffuse fluence at transport depth `t` below the lit face of a slab of
/// transport thickness `total`, per unit normal irradiance of a collimated
/// beam at cosine `mu0` (> 0) on that face, the beam decaying at
/// `beam_rate` ρ (module notes); dimensionless. 0 for mu0 ≤ 0.
pub fn collimated_fluence(t: f64, total: f64, mu0: f64, beam_rate: f64) -> f64 {
    if mu0 <= 0.0 {
        return 0.0;
    }
    let total = total.max(0.0);
    let t = t.clamp(0.0, total);
    let (a, b) = collimated_coefficients(total, mu0, beam_rate);
    (a + b * t - 3.0 * mu0 * mu0 * (-beam_rate * t / mu0).exp()).max(0.0)
}

/// A and B of the beam's solution Φ = A + B t − 3 μ₀² e^{−ρt/μ₀} (module
/// notes), per unit normal irradiance, for a slab of transport thickness
/// `total` (≥ 0), a beam at cosine `mu0` (> 0) and beam rate ρ.
fn collimated_coefficients(total: f64, mu0: f64, beam_rate: f64) -> (f64, f64) {
    let e = (-beam_rate * total / mu0).exp();
    let b = -(3.0 * mu0 * mu0 * (1.0 - e) + 2.0 * mu0 * (1.0 + e)) / (total + 4.0 / 3.0);
    (3.0 * mu0 * mu0 + 2.0 * mu0 + 2.0 / 3.0 * b, b)
}

/// Net diffuse flux along the depth axis (into the slab, away from the lit
/// face) at transport depth `t` of [`collimated_fluence`]'s slab, per unit
/// normal irradiance: −B/3 − μ₀ e^{−ρt/μ₀}. 0 for mu0 ≤ 0.
pub fn collimated_net_flux(t: f64, total: f64, mu0: f64, beam_rate: f64) -> f64 {
    if mu0 <= 0.0 {
        return 0.0;
    }
    let total = total.max(0.0);
    let t = t.clamp(0.0, total);
    let (_, b) = collimated_coefficients(total, mu0, beam_rate);
    -b / 3.0 - mu0 * (-beam_rate * t / mu0).exp()
}

/// Diffuse fluence at transport depth `t` below the top of a slab of
/// transport thickness `total` lit by the diffuse fluxes `flux_top` and
/// `flux_base` entering its faces (W m⁻²), W m⁻².
pub fn diffuse_fluence(t: f64, total: f64, flux_top: f64, flux_base: f64) -> f64 {
    let total = total.max(0.0);
    let t = t.clamp(0.0, total);
    let b = 4.0 * (flux_base - flux_top) / (total + 4.0 / 3.0);
    let a = 4.0 * flux_top + 2.0 / 3.0 * b;
    (a + b * t).max(0.0)
}

/// Net flux (downwards, W m⁻²) of [`diffuse_fluence`]'s slab, −Φ′/3:
/// 4 (F_top − F_base)/(3 T + 4).
pub fn diffuse_net_flux(total: f64, flux_top: f64, flux_base: f64) -> f64 {
    4.0 * (flux_top - flux_base) / (3.0 * total.max(0.0) + 4.0)
}

/// Eddington's radiance (W m⁻² sr⁻¹ for Φ in W m⁻²) of a fluence `fluence`
/// and a net flux `net_flux` along the depth axis, for light travelling at
/// cosine `mu` to that axis: (Φ + 3 μ F)/(4π), never below 0.
pub fn eddington_radiance(fluence: f64, net_flux: f64, mu: f64) -> f64 {
    (fluence + 3.0 * mu * net_flux).max(0.0) / (4.0 * std::f64::consts::PI)
}

/// The light of that P1 field scattered towards a direction at cosine `mu`
/// to the depth axis by droplets of asymmetry `asymmetry` (the
/// Henyey–Greenstein expansion's first two terms, 1 + 3 g cos θ), per unit
/// scattering optical depth, W m⁻² sr⁻¹: (Φ + 3 g μ F)/(4π). A march along
/// a view ray integrates this source, and not the field's radiance
/// [`eddington_radiance`], whose integral counts the flux twice: the
/// radiance the march builds up is already the field's, I = ∫ S e^{−τ} dτ
/// (for a slab field linear in depth, exactly (Φ + 3 μ F)/(4π) deep inside
/// a conservative medium).
pub fn eddington_source(fluence: f64, net_flux: f64, mu: f64, asymmetry: f64) -> f64 {
    eddington_radiance(fluence, asymmetry * net_flux, mu)
}

/// The exact escape function over Eddington's emergent distribution,
/// both per unit flux, at cosine `mu` to a thick conservative slab's
/// normal: u(μ)/u_E(μ) = (12/7)(1 + 2μ)/(2 + 3μ), dimensionless.
///
/// Marching the P1 source [`eddington_source`] out of a slab gives the
/// light leaving it by u_E(μ) = (2 + 3μ)/4 of the flux per π (whatever the
/// droplets' asymmetry: the source's gradient and its anisotropic part add
/// up to it); the light leaves by the escape function u(μ) = (3/7)(1 + 2μ)
/// (Chandrasekhar's H-function of conservative scattering normalised to
/// unit flux, [`crate::transport::stratus::escape_function`]), which the
/// slab photon tracer follows: P1 is 6 % too bright 70–80° from the
/// normal and 19 % at 82.5°, the corrected light within 3.5 % out to 77.5°
/// (tests/eddington_exit.rs). By reciprocity the same ratio of the beam's
/// cosine corrects what a collimated beam puts into a thick slab
/// ((μ₀ + ⅔)/(T + 4/3) in the P1 solution, [`collimated_fluence`]): 10 %
/// too much under a sun 14° high, within 2.5 % once corrected. 0.857 at
/// μ = 0, 1 near μ = 0.7, 1.029 at μ = 1.
pub fn escape_over_eddington(mu: f64) -> f64 {
    let m = mu.clamp(0.0, 1.0);
    crate::transport::stratus::escape_function(m) / ((2.0 + 3.0 * m) / 4.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn derivative(f: impl Fn(f64) -> f64, t: f64) -> f64 {
        let h = 1e-5;
        (f(t + h) - f(t - h)) / (2.0 * h)
    }

    const RATES: [f64; 2] = [1.0, 1.85];

    /// Marshak's conditions hold on both faces: nothing diffuse enters a
    /// slab lit by a beam alone (Φ + 2F = 0 on the top, Φ − 2F = 0 on the
    /// base), for the similarity and the δ-Eddington beam.
    #[test]
    fn collimated_fluence_meets_the_boundary_conditions() {
        for rate in RATES {
            for (total, mu0) in [(0.5, 0.3), (4.0, 0.8), (20.0, 0.5)] {
                let top = collimated_fluence(0.0, total, mu0, rate)
                    + 2.0 * collimated_net_flux(0.0, total, mu0, rate);
                let base = collimated_fluence(total, total, mu0, rate)
                    - 2.0 * collimated_net_flux(total, total, mu0, rate);
                assert!(top.abs() < 1e-9, "{rate} {total} {mu0}: {top}");
                assert!(base.abs() < 1e-9, "{rate} {total} {mu0}: {base}");
            }
        }
    }

    /// The moment equations: the diffuse flux grows by what the beam loses,
    /// dF/dt = ρ e^{−ρt/μ₀}, so the net flux, diffuse plus beam μ₀ e^{−ρt/μ₀},
    /// is the same at every depth; ⅓ Φ′ = −F + (ρ − 1) μ₀ e^{−ρt/μ₀}; and
    /// the transmission is the classical diffusion (μ₀ + ⅔)/(T + 4/3) of a
    /// thick slab (Bohren & Clothiaux 2006, eq. 6.85 with ϖ = 1).
    #[test]
    fn collimated_flux_is_conserved_and_transmission_is_the_diffusion_one() {
        let (total, mu0) = (30.0, 0.6);
        for rate in RATES {
            let beam = |t: f64| mu0 * (-rate * t / mu0).exp();
            let net = |t: f64| collimated_net_flux(t, total, mu0, rate) + beam(t);
            let first = net(1.0);
            for t in [3.0, 10.0, 20.0, 29.0] {
                assert!((net(t) - first).abs() < 1e-9, "{t}: {} vs {first}", net(t));
                let fick = derivative(|x| collimated_fluence(x, total, mu0, rate), t) / 3.0;
                let expected = -collimated_net_flux(t, total, mu0, rate) + (rate - 1.0) * beam(t);
                assert!(
                    (fick - expected).abs() < 1e-6,
                    "{rate} {t}: {fick} vs {expected}"
                );
            }
            let expected = mu0 * (mu0 + 2.0 / 3.0) / (total + 4.0 / 3.0);
            assert!(
                (first / expected - 1.0).abs() < 1e-6,
                "{first} vs {expected}"
            );
            // A thin slab passes nearly everything.
            assert!(collimated_fluence(0.0, 1e-3, mu0, rate) < 1e-2);
        }
        // The δ-Eddington beam hands its light to the diffuse field sooner:
        // more fluence near the lit face.
        assert!(
            collimated_fluence(1.0, total, mu0, 1.85) > collimated_fluence(1.0, total, mu0, 1.0)
        );
        assert_eq!(delta_eddington_beam_rate(0.85), 1.85);
    }

    /// An isotropic field of radiance L (flux π L on both faces) stays
    /// isotropic inside a conservative slab: Φ = 4π L everywhere, F = 0.
    #[test]
    fn isotropic_illumination_gives_a_uniform_fluence() {
        let l = 2.5;
        let flux = std::f64::consts::PI * l;
        for t in [0.0, 1.0, 7.0, 12.0] {
            let phi = diffuse_fluence(t, 12.0, flux, flux);
            assert!((phi - 4.0 * std::f64::consts::PI * l).abs() < 1e-9);
        }
        assert_eq!(diffuse_net_flux(12.0, flux, flux), 0.0);
        // Light from above only dims with depth, and meets Marshak's
        // conditions: 4 F on the top, 0 on the base; F = −Φ′/3.
        let f = |t: f64| diffuse_fluence(t, 12.0, 1.0, 0.0);
        let net = diffuse_net_flux(12.0, 1.0, 0.0);
        assert!(f(0.0) > f(6.0) && f(6.0) > f(12.0));
        assert!((f(0.0) + 2.0 * net - 4.0).abs() < 1e-9);
        assert!((f(12.0) - 2.0 * net).abs() < 1e-9);
        assert!((derivative(f, 6.0) / -3.0 - net).abs() < 1e-6);
    }

    /// The radiance carries the flux: ∫ I μ dω = F, and its mean over the
    /// sphere is Φ/(4π); inside a slab lit from above, looking up is
    /// brighter than looking level.
    #[test]
    fn radiance_carries_the_flux() {
        let (phi, net_flux) = (5.0, 0.4);
        let n = 20_000;
        let (mut flux, mut mean) = (0.0, 0.0);
        for k in 0..n {
            let mu = -1.0 + 2.0 * (k as f64 + 0.5) / n as f64;
            let radiance = eddington_radiance(phi, net_flux, mu);
            flux += radiance * mu * 2.0 * std::f64::consts::PI * 2.0 / n as f64;
            mean += radiance / n as f64;
        }
        assert!((flux - net_flux).abs() < 1e-6, "flux {flux}");
        assert!((mean - phi / (4.0 * std::f64::consts::PI)).abs() < 1e-9);
        let (t, total, mu0, rate) = (3.0, 6.0, 0.7, 1.85);
        let phi = collimated_fluence(t, total, mu0, rate);
        let net_flux = collimated_net_flux(t, total, mu0, rate);
        assert!(
            eddington_radiance(phi, net_flux, 1.0) > 1.2 * eddington_radiance(phi, net_flux, 0.0)
        );
    }

    /// A march integrating the source along a view ray through a field
    /// linear in depth (Fick's law for droplets of asymmetry g in units of
    /// their scattering optical depth, Φ′ = −3 (1 − g) F) builds up the
    /// field's own radiance (Φ + 3 μ F)/(4π) at its end.
    #[test]
    fn marching_the_source_gives_the_fields_radiance() {
        let (phi0, flux, g) = (30.0, 0.8, 0.75);
        for mu in [-0.9, -0.3, 0.0, 0.4, 1.0] {
            // Light travelling at cosine μ to the axis reaches depth 0 from
            // depth −μ s, s the optical path back along the ray.
            let n = 200_000;
            let length = 40.0;
            let ds = length / n as f64;
            let marched: f64 = (0..n)
                .map(|k| {
                    let s = (k as f64 + 0.5) * ds;
                    let phi = phi0 + 3.0 * (1.0 - g) * flux * mu * s;
                    eddington_source(phi, flux, mu, g) * (-s).exp() * ds
                })
                .sum();
            let expected = eddington_radiance(phi0, flux, mu);
            assert!(
                (marched / expected - 1.0).abs() < 1e-6,
                "μ {mu}: {marched} vs {expected}"
            );
        }
    }
}
