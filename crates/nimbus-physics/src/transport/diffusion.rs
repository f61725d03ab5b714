//! The light inside a conservative cloud slab in the diffusion
//! approximation: what a camera inside the stratus layer sees scattered
//! towards it (nimbus-render's `passes/stratus/in_layer.wgsl` is the twin).
//!
//! The slab is taken by similarity (van de Hulst 1980, §14.6) as an
//! isotropically scattering one of transport optical depth t = (1 − g) κ z
//! (κ the extinction, g the droplets' asymmetry, z the depth below the lit
//! face), total T = (1 − g) κ h. The diffuse fluence Φ (W m⁻², all
//! directions) obeys −⅓ Φ'' = S(t), S the first scattering of the direct
//! beam, with Marshak's boundary conditions Φ ∓ ⅔ Φ' = 4 F_in on the top
//! and the base, F_in the diffuse flux entering there (the Eddington
//! two-stream of Meador & Weaver 1980 for ϖ = 1, written for the fluence).
//! Solutions, linear plus the beam's term:
//!
//! - collimated beam of normal irradiance E at cosine μ₀ on the top:
//!   Φ = A + B t − 3 E μ₀² e^{−t/μ₀},
//!   B = −E [3 μ₀² (1 − e) + 2 μ₀ (1 + e)] / (T + 4/3), e = e^{−T/μ₀},
//!   A = 3 E μ₀² + 2 E μ₀ + ⅔ B;
//!   its total transmission −B/(3 μ₀ E) = (μ₀ + ⅔)/(T + 4/3) as T grows,
//!   the classical diffusion result.
//! - diffuse fluxes F_top, F_base entering the faces:
//!   Φ = A + B t, B = 4 (F_base − F_top)/(T + 4/3), A = 4 F_top + ⅔ B;
//!   an isotropic field (F_top = F_base = π L) gives Φ = 4π L everywhere.
//!
//! The radiance (Eddington's P1, the first two terms of its angular
//! expansion): I(μ) = (Φ + 3 F μ)/(4π), F = −⅓ dΦ/dt the net flux along
//! the depth axis (Fick's law), μ the cosine between the light's direction
//! of travel and that axis; so I = (Φ − μ Φ')/(4π) ([`eddington_radiance`]).
//! Looking up into an overcast (the light travelling down the axis, μ = 1)
//! the radiance is above the fluence's isotropic part Φ/(4π), looking down
//! below it.
//!
//! Units: t, T dimensionless; E, F in W m⁻², Φ in W m⁻².

/// Diffuse fluence at transport depth `t` below the lit face of a slab of
/// transport thickness `total`, per unit normal irradiance of a collimated
/// beam at cosine `mu0` (> 0) on that face; dimensionless. 0 for mu0 ≤ 0.
pub fn collimated_fluence(t: f64, total: f64, mu0: f64) -> f64 {
    if mu0 <= 0.0 {
        return 0.0;
    }
    let total = total.max(0.0);
    let t = t.clamp(0.0, total);
    let (a, b) = collimated_coefficients(total, mu0);
    (a + b * t - 3.0 * mu0 * mu0 * (-t / mu0).exp()).max(0.0)
}

/// A and B of the beam's solution Φ = A + B t − 3 μ₀² e^{−t/μ₀} (module
/// notes), per unit normal irradiance, for a slab of transport thickness
/// `total` (≥ 0) and a beam at cosine `mu0` (> 0).
fn collimated_coefficients(total: f64, mu0: f64) -> (f64, f64) {
    let e = (-total / mu0).exp();
    let b = -(3.0 * mu0 * mu0 * (1.0 - e) + 2.0 * mu0 * (1.0 + e)) / (total + 4.0 / 3.0);
    (3.0 * mu0 * mu0 + 2.0 * mu0 + 2.0 / 3.0 * b, b)
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

/// dΦ/dt of [`collimated_fluence`] (per unit normal irradiance), the
/// unclamped solution's: B + 3 μ₀ e^{−t/μ₀}. 0 for mu0 ≤ 0.
pub fn collimated_fluence_gradient(t: f64, total: f64, mu0: f64) -> f64 {
    if mu0 <= 0.0 {
        return 0.0;
    }
    let total = total.max(0.0);
    let t = t.clamp(0.0, total);
    let (_, b) = collimated_coefficients(total, mu0);
    b + 3.0 * mu0 * (-t / mu0).exp()
}

/// dΦ/dt of [`diffuse_fluence`], W m⁻²: 4 (F_base − F_top)/(T + 4/3).
pub fn diffuse_fluence_gradient(total: f64, flux_top: f64, flux_base: f64) -> f64 {
    4.0 * (flux_base - flux_top) / (total.max(0.0) + 4.0 / 3.0)
}

/// Eddington's radiance (W m⁻² sr⁻¹ for Φ in W m⁻²) of a fluence `fluence`
/// and its gradient `gradient` along the depth axis, for light travelling
/// at cosine `mu` to that axis: (Φ − μ Φ')/(4π), never below 0.
pub fn eddington_radiance(fluence: f64, gradient: f64, mu: f64) -> f64 {
    (fluence - mu * gradient).max(0.0) / (4.0 * std::f64::consts::PI)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn derivative(f: impl Fn(f64) -> f64, t: f64) -> f64 {
        let h = 1e-5;
        (f(t + h) - f(t - h)) / (2.0 * h)
    }

    /// Marshak's conditions hold on both faces: nothing diffuse enters a
    /// slab lit by a beam alone.
    #[test]
    fn collimated_fluence_meets_the_boundary_conditions() {
        for (total, mu0) in [(0.5, 0.3), (4.0, 0.8), (20.0, 0.5)] {
            let f = |t: f64| collimated_fluence(t, total, mu0);
            let top = f(0.0) - 2.0 / 3.0 * derivative(f, 1e-4);
            let base = f(total) + 2.0 / 3.0 * derivative(f, total - 1e-4);
            assert!(top.abs() < 1e-3, "{total} {mu0}: {top}");
            assert!(base.abs() < 1e-3, "{total} {mu0}: {base}");
        }
    }

    /// Conservation: the net downward flux, diffuse −⅓ Φ' plus direct
    /// μ₀ e^{−t/μ₀}, is the same at every depth, and the transmission is the
    /// classical diffusion (μ₀ + ⅔)/(T + 4/3) of a thick slab (Bohren &
    /// Clothiaux 2006, eq. 6.85 with ϖ = 1).
    #[test]
    fn collimated_flux_is_conserved_and_transmission_is_the_diffusion_one() {
        let (total, mu0) = (30.0, 0.6);
        let f = |t: f64| collimated_fluence(t, total, mu0);
        let net = |t: f64| -derivative(f, t) / 3.0 + mu0 * (-t / mu0).exp();
        let first = net(1.0);
        for t in [3.0, 10.0, 20.0, 29.0] {
            assert!((net(t) - first).abs() < 1e-6, "{t}: {} vs {first}", net(t));
        }
        let expected = mu0 * (mu0 + 2.0 / 3.0) / (total + 4.0 / 3.0);
        assert!(
            (first / expected - 1.0).abs() < 1e-6,
            "{first} vs {expected}"
        );
        // A thin slab passes nearly everything.
        let thin = |t: f64| collimated_fluence(t, 1e-3, mu0);
        assert!(thin(0.0) < 1e-2);
    }

    /// An isotropic field of radiance L (flux π L on both faces) stays
    /// isotropic inside a conservative slab: Φ = 4π L everywhere.
    #[test]
    fn isotropic_illumination_gives_a_uniform_fluence() {
        let l = 2.5;
        for t in [0.0, 1.0, 7.0, 12.0] {
            let phi = diffuse_fluence(t, 12.0, std::f64::consts::PI * l, std::f64::consts::PI * l);
            assert!((phi - 4.0 * std::f64::consts::PI * l).abs() < 1e-9);
        }
        // Light from above only dims with depth, and meets Marshak's
        // conditions: 4 F on the top, 0 on the base.
        let f = |t: f64| diffuse_fluence(t, 12.0, 1.0, 0.0);
        assert!(f(0.0) > f(6.0) && f(6.0) > f(12.0));
        assert!((f(0.0) - 2.0 / 3.0 * derivative(f, 1e-4) - 4.0).abs() < 1e-6);
        assert!((f(12.0) + 2.0 / 3.0 * derivative(f, 12.0 - 1e-4)).abs() < 1e-6);
    }

    /// The gradients are the fluences' derivatives, and the radiance
    /// carries the flux: ∫ I μ dω = −⅓ Φ' (Fick), and its mean over the
    /// sphere is Φ/(4π); inside a slab lit from above, looking up is
    /// brighter than looking level.
    #[test]
    fn gradients_and_radiance_carry_the_flux() {
        for (t, total, mu0) in [(0.3, 2.0, 0.7), (1.5, 6.0, 0.4), (4.0, 9.0, 1.0)] {
            let numeric = derivative(|x| collimated_fluence(x, total, mu0), t);
            let exact = collimated_fluence_gradient(t, total, mu0);
            assert!((numeric - exact).abs() < 1e-5, "{numeric} vs {exact}");
            let numeric = derivative(|x| diffuse_fluence(x, total, 2.0, 0.3), t);
            let exact = diffuse_fluence_gradient(total, 2.0, 0.3);
            assert!((numeric - exact).abs() < 1e-6, "{numeric} vs {exact}");
        }
        let (phi, gradient) = (5.0, -1.2);
        let n = 20_000;
        let (mut flux, mut mean) = (0.0, 0.0);
        for k in 0..n {
            let mu = -1.0 + 2.0 * (k as f64 + 0.5) / n as f64;
            let radiance = eddington_radiance(phi, gradient, mu);
            flux += radiance * mu * 2.0 * std::f64::consts::PI * 2.0 / n as f64;
            mean += radiance / n as f64;
        }
        assert!((flux + gradient / 3.0).abs() < 1e-6, "flux {flux}");
        assert!((mean - phi / (4.0 * std::f64::consts::PI)).abs() < 1e-9);
        let t = 3.0;
        let phi = collimated_fluence(t, 6.0, 0.7);
        let gradient = collimated_fluence_gradient(t, 6.0, 0.7);
        assert!(
            eddington_radiance(phi, gradient, 1.0) > 1.2 * eddington_radiance(phi, gradient, 0.0)
        );
    }
}
