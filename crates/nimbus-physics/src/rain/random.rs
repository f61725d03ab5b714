//! Stateless random numbers shared by the CPU reference and the GPU rain
//! simulation (`rain/simulation.wgsl` has the same functions): a number is
//! a hash of (drop id, step index, purpose), so the result of a step does not
//! depend on the order drops are processed in, on threads or on workgroups.
//!
//! The hash is the PCG-RXS-M-XS 32-bit output permutation recommended for GPU
//! hashing by Jarzynski & Olano, "Hash Functions for GPU Rendering", JCGT 9(3),
//! 2020.

/// PCG hash of one 32-bit word (Jarzynski & Olano 2020, `pcg`).
#[inline]
pub fn pcg_hash(input: u32) -> u32 {
    let state = input.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28).wrapping_add(4))) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// A uniform number in the open interval (0, 1) for a drop, a step and a
/// purpose (`salt`): 24 random bits, centred in their bin so that ln(u) is
/// always finite.
#[inline]
pub fn uniform(id: u32, step: u32, salt: u32) -> f32 {
    let h = pcg_hash(id ^ pcg_hash(step ^ pcg_hash(salt)));
    ((h >> 8) as f32 + 0.5) * (1.0 / 16_777_216.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_is_in_the_open_unit_interval_and_flat() {
        // χ² over 16 bins of 160 000 draws: 15 degrees of freedom, the
        // 99.9 % quantile is 37.7.
        let mut bins = [0u32; 16];
        let n = 160_000u32;
        for id in 0..n {
            let u = uniform(id, 7, 3);
            assert!(u > 0.0 && u < 1.0);
            bins[(u * 16.0) as usize] += 1;
        }
        let expected = n as f64 / 16.0;
        let chi2: f64 = bins
            .iter()
            .map(|&b| (b as f64 - expected).powi(2) / expected)
            .sum();
        assert!(chi2 < 37.7, "χ² = {chi2}");
    }

    #[test]
    fn purposes_and_steps_are_decorrelated() {
        let n = 100_000;
        let mut sum_xy = 0.0f64;
        for id in 0..n {
            let x = uniform(id, 1, 0) as f64 - 0.5;
            let y = uniform(id, 1, 1) as f64 - 0.5;
            let z = uniform(id, 2, 0) as f64 - 0.5;
            sum_xy += x * y + x * z;
        }
        // Each product has variance 1/144; the sum of 2n has σ ≈ 0.0118·√n·…
        let sigma = (2.0 * n as f64 / 144.0).sqrt();
        assert!(sum_xy.abs() < 5.0 * sigma, "{sum_xy} vs σ {sigma}");
    }
}
