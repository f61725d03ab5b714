//! Photometric conventions: how nimbus's RGB radiance relates to luminance and
//! to a photographic exposure.
//!
//! nimbus carries radiance per linear Rec.709 channel in W·sr⁻¹·m⁻². The
//! channels are "luminous-equivalent": a neutral colour with R = G = B = L has
//! luminance `683 lm/W × L` cd/m², i.e. luminance is
//! `K_m × (0.2126 R + 0.7152 G + 0.0722 B)` with the maximum luminous efficacy
//! K_m = 683 lm/W (CIE). Irradiance uses the same convention in W·m⁻².
//!
//! Exposure follows the saturation-based sensor model used by Frostbite
//! (Lagarde & de Rousiers, "Moving Frostbite to PBR", SIGGRAPH 2014, §4.2):
//! the luminance that saturates the sensor is `L_max = 1.2 × 2^EV100` cd/m².

/// Maximum luminous efficacy K_m of photopic vision, lm/W (CIE).
pub const MAX_LUMINOUS_EFFICACY_LM_PER_W: f64 = 683.0;

/// Rec.709 / sRGB luminance weights of the linear R, G, B channels.
pub const REC709_LUMA: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Luminance in cd/m² of an RGB radiance in W·sr⁻¹·m⁻².
pub fn luminance_cd_m2(radiance_rgb: [f64; 3]) -> f64 {
    MAX_LUMINOUS_EFFICACY_LM_PER_W
        * (REC709_LUMA[0] * radiance_rgb[0]
            + REC709_LUMA[1] * radiance_rgb[1]
            + REC709_LUMA[2] * radiance_rgb[2])
}

/// Illuminance in lux of an RGB irradiance in W·m⁻².
pub fn illuminance_lux(irradiance_rgb: [f64; 3]) -> f64 {
    luminance_cd_m2(irradiance_rgb)
}

/// Scale that maps RGB radiance (W·sr⁻¹·m⁻²) to exposed sensor values, where
/// 1.0 is the saturation luminance `1.2 × 2^EV100` cd/m² (Lagarde 2014, eq. 12).
pub fn exposure_scale_from_ev100(ev100: f64) -> f64 {
    MAX_LUMINOUS_EFFICACY_LM_PER_W / (1.2 * 2f64.powf(ev100))
}

/// Converts CIE XYZ tristimulus values to linear Rec.709 RGB (D65 white),
/// using the matrix of IEC 61966-2-1 (sRGB).
pub fn rec709_from_xyz(xyz: [f64; 3]) -> [f64; 3] {
    let [x, y, z] = xyz;
    [
        3.240_454_2 * x - 1.537_138_5 * y - 0.498_531_4 * z,
        -0.969_266_0 * x + 1.876_010_8 * y + 0.041_556_0 * z,
        0.055_643_4 * x - 0.204_025_9 * y + 1.057_225_2 * z,
    ]
}

/// Converts CIE xyY chromaticity and luminance to XYZ.
pub fn xyz_from_xy_y(x: f64, y: f64, luminance: f64) -> [f64; 3] {
    if y <= 0.0 {
        return [0.0; 3];
    }
    [x * luminance / y, luminance, (1.0 - x - y) * luminance / y]
}

/// sRGB transfer function (IEC 61966-2-1): linear value in [0, 1] to encoded.
pub fn srgb_encode(linear: f64) -> f64 {
    let c = linear.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Inverse of [`srgb_encode`].
pub fn srgb_decode(encoded: f64) -> f64 {
    let c = encoded.clamp(0.0, 1.0);
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// CIE 1976 L*a*b* (D65 white, CIE 15:2004 §8.2.1) of an sRGB-encoded
/// 8-bit colour: sRGB's linear RGB to XYZ (IEC 61966-2-1), then L* in
/// [0, 100]. Dimensionless.
pub fn srgb8_to_cie_lab(rgb: [u8; 3]) -> [f64; 3] {
    let lin = rgb.map(|c| srgb_decode(f64::from(c) / 255.0));
    let x = 0.4124 * lin[0] + 0.3576 * lin[1] + 0.1805 * lin[2];
    let y = 0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2];
    let z = 0.0193 * lin[0] + 0.1192 * lin[1] + 0.9505 * lin[2];
    let f = |t: f64| {
        if t > 216.0 / 24389.0 {
            t.cbrt()
        } else {
            (24389.0 / 27.0 * t + 16.0) / 116.0
        }
    };
    let (fx, fy, fz) = (f(x / 0.95047), f(y), f(z / 1.08883));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// CIE76 colour difference ΔE*ab of two sRGB-encoded 8-bit colours.
pub fn delta_e76(a: [u8; 3], b: [u8; 3]) -> f64 {
    let (la, lb) = (srgb8_to_cie_lab(a), srgb8_to_cie_lab(b));
    ((la[0] - lb[0]).powi(2) + (la[1] - lb[1]).powi(2) + (la[2] - lb[2]).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// White is L* 100 and neutral, black L* 0; sRGB red is the published
    /// L*a*b* (53.24, 80.09, 67.20) to 0.05; ΔE of a colour with itself is 0.
    #[test]
    fn cie_lab_of_srgb_references() {
        let white = srgb8_to_cie_lab([255, 255, 255]);
        assert!((white[0] - 100.0).abs() < 0.01 && white[1].abs() < 0.05 && white[2].abs() < 0.05);
        assert!(srgb8_to_cie_lab([0, 0, 0])[0].abs() < 1e-9);
        let red = srgb8_to_cie_lab([255, 0, 0]);
        for (v, r) in red.iter().zip([53.24, 80.09, 67.20]) {
            assert!((v - r).abs() < 0.05, "{red:?}");
        }
        assert_eq!(delta_e76([10, 200, 30], [10, 200, 30]), 0.0);
    }

    #[test]
    fn d65_white_point_maps_to_equal_rgb() {
        // D65 chromaticity (CIE 15:2004): x = 0.3127, y = 0.3290.
        let rgb = rec709_from_xyz(xyz_from_xy_y(0.3127, 0.3290, 1.0));
        for c in rgb {
            assert!((c - 1.0).abs() < 2e-3, "{rgb:?}");
        }
    }

    #[test]
    fn srgb_round_trips() {
        for k in 0..=100 {
            let v = k as f64 / 100.0;
            assert!((srgb_decode(srgb_encode(v)) - v).abs() < 1e-12);
        }
        // Mid-grey 0.5 encodes to 0.7354 (IEC 61966-2-1).
        assert!((srgb_encode(0.5) - 0.735_357).abs() < 1e-5);
    }

    #[test]
    fn sunny_sixteen_exposure_maps_sunlit_grey_card_below_saturation() {
        // A Lambertian 18 % grey card under 100 klx has L = 0.18 × 1e5 / π ≈ 5730 cd/m²;
        // at EV100 = 15 (sunny-16 rule) the saturation luminance is 1.2 × 2^15 ≈ 39 300 cd/m².
        let radiance = 0.18 * 1.0e5 / std::f64::consts::PI / MAX_LUMINOUS_EFFICACY_LM_PER_W;
        let exposed = radiance * exposure_scale_from_ev100(15.0);
        assert!((exposed - 5729.6 / 39321.6).abs() < 1e-3, "{exposed}");
    }
}
