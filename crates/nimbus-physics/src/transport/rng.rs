//! A small, fast, seedable random number generator for the photon tracer:
//! xoshiro256++ (Blackman & Vigna, "Scrambled linear pseudorandom number
//! generators", ACM TOMS 47, 2021), seeded through SplitMix64 (Steele, Lea &
//! Flood 2014) so that any 64-bit seed and stream index give a well-mixed,
//! independent-looking state. Streams are keyed by (seed, batch), which makes
//! the tracer's results independent of how threads pick up batches.

/// xoshiro256++ state.
#[derive(Clone, Debug)]
pub struct Rng {
    s: [u64; 4],
}

/// One step of SplitMix64.
fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl Rng {
    /// The generator of stream `stream` for seed `seed`.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut state = seed ^ stream.wrapping_mul(0xd134_2543_de82_ef95);
        // Mix the stream index in twice so nearby (seed, stream) pairs differ.
        let _ = splitmix64(&mut state);
        state ^= stream;
        let s = [0; 4].map(|_| splitmix64(&mut state));
        Self { s }
    }

    /// The next 64 random bits.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let result = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// A uniform number in [0, 1) with 53 random bits.
    #[inline]
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// A uniform number in (0, 1], safe for a logarithm.
    #[inline]
    pub fn uniform_open0(&mut self) -> f64 {
        ((self.next_u64() >> 11) + 1) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_numbers_have_the_right_mean_and_variance_and_streams_differ() {
        let mut rng = Rng::new(42, 0);
        let n = 1_000_000;
        let (mut sum, mut sum2) = (0.0, 0.0);
        for _ in 0..n {
            let u = rng.uniform();
            assert!((0.0..1.0).contains(&u));
            sum += u;
            sum2 += u * u;
        }
        let mean = sum / n as f64;
        let variance = sum2 / n as f64 - mean * mean;
        // Mean ½ with standard error √(1/12/n) ≈ 2.9e-4; variance 1/12.
        assert!((mean - 0.5).abs() < 1.5e-3, "{mean}");
        assert!((variance - 1.0 / 12.0).abs() < 1e-3, "{variance}");
        let a: Vec<u64> = (0..4).map(|_| Rng::new(42, 1).next_u64()).collect();
        let b = Rng::new(42, 2).next_u64();
        assert_ne!(a[0], b);
        assert_eq!(Rng::new(7, 3).next_u64(), Rng::new(7, 3).next_u64());
    }
}
