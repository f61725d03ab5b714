//! Real spherical harmonics up to order 2 (nine coefficients) for a
//! low-order directional representation of environment radiance, and the
//! irradiance it delivers to a Lambertian surface.
//!
//! Reference: Ramamoorthi & Hanrahan, "An Efficient Representation for
//! Irradiance Environment Maps", SIGGRAPH 2001: basis constants (eq. 3) and
//! the cosine-lobe convolution Â₀ = π, Â₁ = 2π/3, Â₂ = π/4 (eq. 8). Directions
//! are unit vectors (x, y, z) in any fixed frame; radiance per RGB channel in
//! W·sr⁻¹·m⁻², irradiance in W·m⁻².

/// The nine real SH basis functions at a unit direction.
pub fn basis(d: [f64; 3]) -> [f64; 9] {
    let [x, y, z] = d;
    [
        0.282_095,
        0.488_603 * y,
        0.488_603 * z,
        0.488_603 * x,
        1.092_548 * x * y,
        1.092_548 * y * z,
        0.315_392 * (3.0 * z * z - 1.0),
        1.092_548 * x * z,
        0.546_274 * (x * x - y * y),
    ]
}

/// Order of each coefficient (l = 0, 1, 1, 1, 2, …).
const ORDER: [usize; 9] = [0, 1, 1, 1, 2, 2, 2, 2, 2];

/// Cosine-lobe convolution factors per order (Ramamoorthi & Hanrahan 2001, eq. 8).
pub const LAMBERT_CONVOLUTION: [f64; 3] = [
    std::f64::consts::PI,
    2.0 * std::f64::consts::PI / 3.0,
    std::f64::consts::PI / 4.0,
];

/// Projects radiance sampled at `directions` (uniformly distributed over the
/// sphere, equal weights 4π/N) onto the nine coefficients.
pub fn project(directions: &[[f64; 3]], radiance: impl Fn([f64; 3]) -> [f64; 3]) -> [[f64; 3]; 9] {
    let weight = 4.0 * std::f64::consts::PI / directions.len() as f64;
    let mut coefficients = [[0.0; 3]; 9];
    for d in directions {
        let l = radiance(*d);
        for (k, y) in basis(*d).iter().enumerate() {
            for c in 0..3 {
                coefficients[k][c] += l[c] * y * weight;
            }
        }
    }
    coefficients
}

/// Irradiance on a surface with unit normal `n` from SH radiance coefficients.
pub fn irradiance(coefficients: &[[f64; 3]; 9], n: [f64; 3]) -> [f64; 3] {
    let y = basis(n);
    let mut e = [0.0; 3];
    for k in 0..9 {
        for c in 0..3 {
            e[c] += LAMBERT_CONVOLUTION[ORDER[k]] * coefficients[k][c] * y[k];
        }
    }
    e.map(|v| v.max(0.0))
}

/// Radiance reconstructed from SH coefficients in direction `d`.
pub fn radiance(coefficients: &[[f64; 3]; 9], d: [f64; 3]) -> [f64; 3] {
    let y = basis(d);
    let mut l = [0.0; 3];
    for k in 0..9 {
        for c in 0..3 {
            l[c] += coefficients[k][c] * y[k];
        }
    }
    l
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atmosphere::fibonacci_sphere;

    fn directions(n: u32) -> Vec<[f64; 3]> {
        (0..n).map(|k| fibonacci_sphere(k, n)).collect()
    }

    #[test]
    fn constant_radiance_gives_pi_l_irradiance_everywhere() {
        let sh = project(&directions(4096), |_| [2.0, 1.0, 0.5]);
        for n in [
            [0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.6, 0.0, 0.8],
        ] {
            let e = irradiance(&sh, n);
            for (c, l) in [2.0, 1.0, 0.5].iter().enumerate() {
                assert!((e[c] - std::f64::consts::PI * l).abs() < 1e-3, "{e:?}");
            }
        }
    }

    #[test]
    fn upper_hemisphere_light_matches_the_analytic_irradiance() {
        // Uniform radiance L over the upper hemisphere (y > 0): E(up) = πL,
        // E(down) = 0, E(horizontal) = πL/2. Order-2 SH reproduces irradiance
        // to within a few percent of the maximum (Ramamoorthi & Hanrahan 2001, §3: < 3 % on average).
        let sh = project(&directions(8192), |d| {
            if d[1] > 0.0 { [1.0; 3] } else { [0.0; 3] }
        });
        let pi = std::f64::consts::PI;
        for (n, expected) in [
            ([0.0, 1.0, 0.0], pi),
            ([0.0, -1.0, 0.0], 0.0),
            ([1.0, 0.0, 0.0], pi / 2.0),
        ] {
            let e = irradiance(&sh, n)[0];
            assert!(
                (e - expected).abs() < 0.06 * pi,
                "n {n:?}: {e} vs {expected}"
            );
        }
    }
}
