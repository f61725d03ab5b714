//! Importance sampling of tabulated phase functions for the Monte-Carlo
//! photon tracer: the scattering angle is drawn by inverting the exact
//! cumulative distribution of a table that is linear in θ between its
//! points (so a table with 0.05° steps samples the forward peak exactly as
//! tabulated), and the azimuth uniformly.

use super::phase::PhaseTable;

/// Inverse-CDF sampler of a [`PhaseTable`].
#[derive(Clone, Debug)]
pub struct PhaseSampler {
    table: PhaseTable,
    /// Cumulative probability at each table angle (last = 1).
    cdf: Vec<f64>,
}

/// ∫_a^θ 2π sin t (pa + slope (t − a)) dt.
fn partial(a: f64, theta: f64, pa: f64, slope: f64) -> f64 {
    let constant = a.cos() - theta.cos();
    let linear = theta.sin() - (theta - a) * theta.cos() - a.sin();
    2.0 * std::f64::consts::PI * (pa * constant + slope * linear)
}

impl PhaseSampler {
    /// Builds the cumulative distribution of a table.
    pub fn new(table: &PhaseTable) -> Self {
        let a = &table.angles_deg;
        let mut cdf = vec![0.0; a.len()];
        for i in 1..a.len() {
            let (t0, t1) = (a[i - 1].to_radians(), a[i].to_radians());
            let mass = if t1 > t0 {
                let slope = (table.values[i] - table.values[i - 1]) / (t1 - t0);
                partial(t0, t1, table.values[i - 1], slope).max(0.0)
            } else {
                0.0
            };
            cdf[i] = cdf[i - 1] + mass;
        }
        let total = cdf[a.len() - 1];
        for c in &mut cdf {
            *c /= total;
        }
        Self {
            table: table.clone(),
            cdf,
        }
    }

    /// The scattering angle (radians) for a uniform random number u ∈ [0, 1).
    pub fn sample_theta(&self, u: f64) -> f64 {
        let i = self
            .cdf
            .partition_point(|c| *c <= u)
            .clamp(1, self.cdf.len() - 1);
        let a = &self.table.angles_deg;
        let (t0, t1) = (a[i - 1].to_radians(), a[i].to_radians());
        if t1 <= t0 {
            return t0;
        }
        let (p0, p1) = (self.table.values[i - 1], self.table.values[i]);
        let slope = (p1 - p0) / (t1 - t0);
        let mass = partial(t0, t1, p0, slope);
        let target = (u - self.cdf[i - 1]) / (self.cdf[i] - self.cdf[i - 1]).max(1e-300) * mass;
        // The partial integral is monotonic in θ on the interval: bisection.
        let (mut lo, mut hi) = (t0, t1);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if partial(t0, mid, p0, slope) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }

    /// A direction scattered from `incident` (unit vector) for two uniform
    /// random numbers: θ from the table, azimuth uniform.
    pub fn sample_direction(&self, incident: [f64; 3], u1: f64, u2: f64) -> [f64; 3] {
        let theta = self.sample_theta(u1);
        let phi = std::f64::consts::TAU * u2;
        rotate(incident, theta.cos(), theta.sin(), phi)
    }
}

/// The direction at polar angle θ (given by its cosine and sine) and azimuth
/// φ around the unit vector `axis`.
pub fn rotate(axis: [f64; 3], cos_t: f64, sin_t: f64, phi: f64) -> [f64; 3] {
    let [x, y, z] = axis;
    // An orthonormal basis (t, b, axis) (Duff et al., JCGT 2017).
    let sign = if z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + z);
    let b = x * y * a;
    let t = [1.0 + sign * x * x * a, sign * b, -sign * x];
    let bb = [b, sign + y * y * a, -y];
    let (sp, cp) = phi.sin_cos();
    [0, 1, 2].map(|k| sin_t * (cp * t[k] + sp * bb[k]) + cos_t * axis[k])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (PCG-XSH-RR, O'Neill 2014) for the test.
    struct Pcg(u64);
    impl Pcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let x = (((self.0 >> 18) ^ self.0) >> 27) as u32;
            let r = (self.0 >> 59) as u32;
            x.rotate_right(r) as f64 / 4294967296.0
        }
    }

    #[test]
    fn chi_square_test_of_the_sampler_on_a_forward_peaked_table() {
        // HG with g = 0.85 on 0.05° steps; 40 bins of equal expected
        // probability; χ² with 39 degrees of freedom must stay below the
        // 0.1 % critical value 72.05 (NIST/SEMATECH table of χ² quantiles).
        let g: f64 = 0.85;
        let table = PhaseTable::from_fn(3601, |deg| {
            let c = deg.to_radians().cos();
            (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * c).powf(1.5))
        });
        let sampler = PhaseSampler::new(&table);
        let bins = 40;
        // Bin edges at equal probability, from the exact CDF of the table.
        let edges: Vec<f64> = (0..=bins)
            .map(|k| sampler.sample_theta(k as f64 / bins as f64 * 0.999_999_999))
            .collect();
        let mut counts = vec![0u32; bins];
        let mut rng = Pcg(12345);
        let n = 200_000;
        for _ in 0..n {
            let theta = sampler.sample_theta(rng.next());
            let k = edges.partition_point(|e| *e <= theta).clamp(1, bins) - 1;
            counts[k] += 1;
        }
        let expected = n as f64 / bins as f64;
        let chi2: f64 = counts
            .iter()
            .map(|c| (*c as f64 - expected).powi(2) / expected)
            .sum();
        assert!(chi2 < 72.05, "χ² = {chi2}");
        // And the mean cosine of the samples is the table's g within 4 standard errors.
        let mut rng = Pcg(777);
        let mean: f64 = (0..n)
            .map(|_| sampler.sample_theta(rng.next()).cos())
            .sum::<f64>()
            / n as f64;
        let g_table = table.legendre_moments(2)[1];
        assert!(
            (mean - g_table).abs() < 4.0 * (1.0f64 / n as f64).sqrt() * 0.3,
            "{mean} vs {g_table}"
        );
    }

    #[test]
    fn rotated_directions_are_unit_and_at_the_right_angle() {
        for axis in [
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [0.6, 0.0, 0.8],
            [0.0, 1.0, 0.0],
        ] {
            let d = rotate(axis, 0.3f64.cos(), 0.3f64.sin(), 1.2);
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let cos = d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2];
            assert!((len - 1.0).abs() < 1e-12 && (cos - 0.3f64.cos()).abs() < 1e-12);
        }
    }
}
