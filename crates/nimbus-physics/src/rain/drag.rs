//! Drag and terminal fall speed of raindrops.
//!
//! Blanchard (2023, §4.2.1) writes the forces on a drop as gravity, a wind
//! force and quadratic air drag −k·|v|·v on the drop's own velocity v, with a
//! constant drag coefficient C_x in [0.4, 1]. Two changes here, both needed
//! for the drops to move as real ones do:
//!
//! 1. Drag acts on the velocity relative to the air, u = v − W(x, t). The
//!    seed's acceleration, G + c·(|W|·W − |v|·v), has its horizontal steady
//!    state where |v|·v_h = |W|·W, and |v| includes the fall speed: a 2 mm
//!    drop (6.5 m/s) in a 5 m/s wind settles at 3.5 m/s, 30 % short of the
//!    wind. With drag on u the drop converges to the wind exactly.
//! 2. The drag coefficient depends on the diameter: a constant C_x cannot
//!    give both the 2 m/s of a 0.5 mm drop and the 9 m/s of a 5 mm drop
//!    (Gunn & Kinzer 1949). We take the per-mass drag constant from the
//!    measured terminal speed instead: at terminal speed drag balances
//!    gravity, k/m·v_t² = g, so k/m = g/v_t(D)², and
//!    a = g − (g/v_t(D)²)·|u|·u.
//!    The equivalent drag coefficient, C_d = (4/3)·(ρ_w/ρ_a)·g·D/v_t², is
//!    reported by [`drag_coefficient`] (it falls from about 1.3 at 0.5 mm to
//!    0.6 at 5 mm: large drops flatten, small ones are in the intermediate
//!    Reynolds regime).
//!
//! v_t(D) is the fit of Atlas, Srivastava & Sekhon, "Doppler radar
//! characteristics of precipitation at vertical incidence", Rev. Geophys.
//! Space Phys. 11, 1973: v_t = 9.65 − 10.3·e^(−0.6·D) m/s for D in mm, which
//! follows Gunn & Kinzer's measurements within 2.5 % from 0.5 to 5.8 mm.
//! Below 0.5 mm the fit falls off too fast (it reaches zero at 0.11 mm);
//! there the speed is taken proportional to D from its value at 0.5 mm,
//! within 4 % of the measurements down to 0.3 mm.

/// Standard gravity, m/s².
pub const GRAVITY_M_S2: f64 = 9.80665;
/// Density of liquid water, kg/m³.
pub const WATER_DENSITY_KG_M3: f64 = 998.2;
/// Density of air at sea level, 20 °C (Gunn & Kinzer's conditions), kg/m³.
pub const AIR_DENSITY_KG_M3: f64 = 1.204;

/// Diameter below which the fit of Atlas et al. is replaced by a linear law, mm.
pub const LINEAR_BELOW_MM: f64 = 0.5;

/// Gunn & Kinzer, "The terminal velocity of fall for water droplets in
/// stagnant air", J. Meteor. 6, 243–248, 1949, Table 2: (diameter mm,
/// terminal speed m/s) at 1013 hPa and 20 °C.
pub const GUNN_KINZER_1949: [(f64, f64); 24] = [
    (0.3, 1.17),
    (0.4, 1.62),
    (0.5, 2.06),
    (0.6, 2.47),
    (0.7, 2.87),
    (0.8, 3.27),
    (0.9, 3.67),
    (1.0, 4.03),
    (1.2, 4.64),
    (1.4, 5.17),
    (1.6, 5.65),
    (1.8, 6.09),
    (2.0, 6.49),
    (2.4, 7.27),
    (2.8, 7.82),
    (3.0, 8.06),
    (3.4, 8.44),
    (3.8, 8.72),
    (4.0, 8.83),
    (4.4, 8.98),
    (4.8, 9.07),
    (5.0, 9.09),
    (5.4, 9.14),
    (5.8, 9.17),
];

/// Terminal fall speed in still air of a drop of diameter `d_mm`, m/s (see
/// the module's notes: Atlas et al. 1973 above 0.5 mm, linear below).
pub fn terminal_speed_m_s(d_mm: f64) -> f64 {
    let atlas = |d: f64| 9.65 - 10.3 * (-0.6 * d).exp();
    if d_mm >= LINEAR_BELOW_MM {
        atlas(d_mm)
    } else {
        atlas(LINEAR_BELOW_MM) * d_mm.max(0.0) / LINEAR_BELOW_MM
    }
}

/// The same in f32, as the GPU evaluates it.
pub fn terminal_speed_m_s_f32(d_mm: f32) -> f32 {
    let atlas = |d: f32| 9.65 - 10.3 * (-0.6 * d).exp();
    let linear_below = LINEAR_BELOW_MM as f32;
    if d_mm >= linear_below {
        atlas(d_mm)
    } else {
        atlas(linear_below) * d_mm.max(0.0) / linear_below
    }
}

/// Per-mass quadratic drag constant k/m = g/v_t(D)², 1/m: a drop's
/// acceleration is g − (k/m)·|u|·u for its velocity u relative to the air.
pub fn drag_per_mass_per_m(d_mm: f64) -> f64 {
    GRAVITY_M_S2 / terminal_speed_m_s(d_mm).powi(2)
}

/// The drag coefficient C_d that gives the terminal speed,
/// (4/3)·(ρ_w/ρ_a)·g·D/v_t² (dimensionless).
pub fn drag_coefficient(d_mm: f64) -> f64 {
    4.0 / 3.0 * WATER_DENSITY_KG_M3 / AIR_DENSITY_KG_M3 * GRAVITY_M_S2 * d_mm * 1e-3
        / terminal_speed_m_s(d_mm).powi(2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn terminal_speeds_match_gunn_and_kinzer_1949_within_5_percent() {
        for (d, measured) in GUNN_KINZER_1949 {
            let v = terminal_speed_m_s(d);
            let error = (v - measured).abs() / measured;
            assert!(
                error < 0.05,
                "D {d} mm: {v:.3} vs {measured} m/s ({:.1} %)",
                error * 100.0
            );
            if (0.5..=5.0).contains(&d) {
                assert!(error < 0.03, "D {d} mm: {:.1} %", error * 100.0);
            }
        }
    }

    #[test]
    fn drag_coefficient_varies_with_size_as_a_constant_cannot() {
        let small = drag_coefficient(0.5);
        let large = drag_coefficient(5.0);
        assert!(small > 1.0 && small < 1.6, "{small}");
        assert!(large > 0.45 && large < 0.8, "{large}");
    }

    #[test]
    fn f32_matches_f64() {
        for d in [0.1, 0.3, 0.5, 1.0, 2.5, 6.0] {
            let a = terminal_speed_m_s(d);
            let b = terminal_speed_m_s_f32(d as f32) as f64;
            assert!((a - b).abs() < 1e-5 * a.max(1.0));
        }
    }
}
