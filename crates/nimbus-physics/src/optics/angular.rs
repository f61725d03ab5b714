//! Fast angular sums of the Mie series over many scattering angles.
//!
//! The DSD integral needs |S1|² + |S2|² at thousands of angles for thousands
//! of droplet radii, so this sum dominates the cost of cloud optics. Two
//! things make it fast:
//!
//! - Mirror symmetry. π_n(−μ) = (−1)^{n−1} π_n(μ) and τ_n(−μ) = (−1)^n τ_n(μ)
//!   (Bohren & Huffman 1983, §4.4.2), so one recurrence of π_n, τ_n at μ ≥ 0
//!   gives the amplitudes at θ and 180° − θ, if the series is summed in two
//!   parts whose signs flip between them. With
//!   G₁ = Σ_odd a_n π_n + Σ_even b_n τ_n and H₁ = Σ_odd b_n τ_n + Σ_even a_n π_n,
//!   S1(θ) = G₁ + H₁ and S1(180° − θ) = G₁ − H₁; with
//!   G₂ = Σ_odd b_n π_n + Σ_even a_n τ_n and H₂ = Σ_odd a_n τ_n + Σ_even b_n π_n,
//!   S2(θ) = G₂ + H₂ and S2(180° − θ) = G₂ − H₂. Each order adds to each of
//!   the four sums once, so both angles cost what one did.
//! - Blocks of angles held in registers while the order n runs, so the inner
//!   loop is pure multiply–add on vectors, compiled for AVX2 or AVX-512 when
//!   the processor has them (chosen at run time). Each block is two or more
//!   vectors wide: the recurrence of one vector is a chain of dependent
//!   operations, and two chains keep the multiply–add units busy. The loop
//!   then runs at the processor's multiply–add throughput (13 per angle pair
//!   and order: 8 for the sums, 5 for the recurrence), about 0.5 ns per
//!   angle pair and order on one core of the development machine (AMD EPYC,
//!   AVX-512).

use super::resonance::Coefficient;
use num_complex::Complex64;

/// Scattering angles prepared for mirrored evaluation: the distinct values of
/// |cos θ|, and for every requested angle which of them it uses and whether it
/// is the mirrored one (cos θ < 0).
#[derive(Clone, Debug)]
pub struct MirroredAngles {
    /// Distinct |cos θ|, padded with copies of the last to a whole number of
    /// blocks.
    base_mu: Vec<f64>,
    /// Number of distinct values before padding.
    base_count: usize,
    /// Per requested angle: (index into the base, mirrored).
    map: Vec<(usize, bool)>,
}

/// Largest block of angles processed together.
const MAX_LANES: usize = 16;

impl MirroredAngles {
    /// Prepares the cosines `mu` (each in [−1, 1]).
    pub fn new(mu: &[f64]) -> Self {
        let mut order: Vec<usize> = (0..mu.len()).collect();
        order.sort_by(|a, b| mu[*a].abs().total_cmp(&mu[*b].abs()));
        let mut base_mu: Vec<f64> = Vec::new();
        let mut map = vec![(0, false); mu.len()];
        for index in order {
            let magnitude = mu[index].abs();
            // Angles of a regular grid and their mirrors agree to rounding.
            if base_mu.last().is_none_or(|last| magnitude - last > 1e-13) {
                base_mu.push(magnitude);
            }
            map[index] = (base_mu.len() - 1, mu[index] < 0.0);
        }
        let base_count = base_mu.len();
        let padding = base_mu.len().next_multiple_of(MAX_LANES) - base_mu.len();
        let last = base_mu.last().copied().unwrap_or(1.0);
        base_mu.extend(std::iter::repeat_n(last, padding));
        Self {
            base_mu,
            base_count,
            map,
        }
    }

    /// Number of requested angles.
    pub fn len(&self) -> usize {
        self.map.len()
    }

    /// Whether there are no angles.
    pub fn is_empty(&self) -> bool {
        self.map.is_empty()
    }

    /// Number of distinct |cos θ| (the cost of a sum is proportional to it).
    pub fn distinct(&self) -> usize {
        self.base_count
    }
}

/// Scratch space of [`accumulate_intensity`] and [`accumulate_resonance`],
/// reused between calls.
#[derive(Default)]
pub struct IntensityScratch {
    terms: Vec<Term>,
    plus: Vec<f64>,
    minus: Vec<f64>,
    dispersive_plus: Vec<f64>,
    dispersive_minus: Vec<f64>,
}

impl IntensityScratch {
    /// Prepares the terms of coefficients `a`, `b` (n = 1..=N) and output
    /// space for `angles`.
    fn prepare(&mut self, a: &[Complex64], b: &[Complex64], angles: &MirroredAngles) {
        self.terms.clear();
        self.terms
            .extend(a.iter().zip(b).enumerate().map(|(i, (a, b))| {
                let n = (i + 1) as f64;
                let f = (2.0 * n + 1.0) / (n * (n + 1.0));
                Term {
                    ar: f * a.re,
                    ai: f * a.im,
                    br: f * b.re,
                    bi: f * b.im,
                    ..Term::order(n)
                }
            }));
        // An even number of orders, so the loop can take them in (odd, even)
        // pairs; the padding order has zero coefficients.
        if self.terms.len() % 2 == 1 {
            self.terms.push(Term::order((self.terms.len() + 1) as f64));
        }
        let count = angles.base_mu.len();
        for v in [
            &mut self.plus,
            &mut self.minus,
            &mut self.dispersive_plus,
            &mut self.dispersive_minus,
        ] {
            v.resize(count, 0.0);
        }
    }
}

/// One order of the series, pre-scaled: the coefficients times
/// (2n + 1)/(n(n + 1)) and the recurrence constants.
#[derive(Clone, Copy, Default)]
struct Term {
    ar: f64,
    ai: f64,
    br: f64,
    bi: f64,
    /// n.
    n: f64,
    /// 1/n.
    inv_n: f64,
    /// (n + 1)/n.
    c2: f64,
    /// n + 1.
    c3: f64,
}

impl Term {
    /// Order n with zero coefficients.
    fn order(n: f64) -> Self {
        Self {
            n,
            inv_n: 1.0 / n,
            c2: (n + 1.0) / n,
            c3: n + 1.0,
            ..Self::default()
        }
    }
}

/// Adds `scale` · (|S1|² + |S2|²) at every angle of `angles` to `out`
/// (indexed like the cosines `angles` was built from), for the series
/// coefficients `a`, `b` (n = 1..=N).
pub fn accumulate_intensity(
    a: &[Complex64],
    b: &[Complex64],
    angles: &MirroredAngles,
    scale: f64,
    scratch: &mut IntensityScratch,
    out: &mut [f64],
) {
    debug_assert_eq!(out.len(), angles.len());
    scratch.prepare(a, b, angles);
    intensity_sums(
        &scratch.terms,
        &angles.base_mu,
        &mut scratch.plus,
        &mut scratch.minus,
    );
    for (value, &(base, mirrored)) in out.iter_mut().zip(&angles.map) {
        let intensity = if mirrored {
            scratch.minus[base]
        } else {
            scratch.plus[base]
        };
        *value += scale * intensity;
    }
}

/// The intensity as a function of one coefficient. With every other
/// coefficient fixed, c = a_n (or b_n) enters S1 and S2 linearly:
/// S_k = S_k⁰ + c P_k with the single-order patterns P₁ = w_n π_n,
/// P₂ = w_n τ_n for a_n (swapped for b_n), w_n = (2n + 1)/(n(n + 1)), so
/// |S1|² + |S2|² = I⁰ + 2 Re(c Σ_k P_k S̄_k⁰) + |c|² Σ_k P_k². On a resonance
/// c = λ/(1 − is) (see [`super::resonance`]; λ ≤ 1 the damping by
/// absorption, s the detuning in widths), which makes it
///
///   I = I⁰ + L/(1 + s²) + D s/(1 + s²),
///   L = λ² Σ_k P_k² + 2λ Σ_k P_k Re S_k⁰,  D = 2λ Σ_k P_k Im S_k⁰.
///
/// Adds `scale`·L to `lorentzian` and `scale`·D to `dispersive` at every
/// angle of `angles`, for the coefficients `a`, `b` at the resonance, of
/// which the resonant one (`order`, 1-based, and `which`) is left out of S⁰.
#[allow(clippy::too_many_arguments)]
pub fn accumulate_resonance(
    a: &[Complex64],
    b: &[Complex64],
    order: usize,
    which: Coefficient,
    damping: f64,
    angles: &MirroredAngles,
    scale: f64,
    scratch: &mut IntensityScratch,
    lorentzian: &mut [f64],
    dispersive: &mut [f64],
) {
    debug_assert!(order >= 1 && order <= a.len());
    scratch.prepare(a, b, angles);
    let term = &mut scratch.terms[order - 1];
    match which {
        Coefficient::A => (term.ar, term.ai) = (0.0, 0.0),
        Coefficient::B => (term.br, term.bi) = (0.0, 0.0),
    }
    resonance_sums(
        &scratch.terms,
        &angles.base_mu,
        order,
        which,
        damping,
        [
            &mut scratch.plus,
            &mut scratch.minus,
            &mut scratch.dispersive_plus,
            &mut scratch.dispersive_minus,
        ],
    );
    for ((l, d), &(base, mirrored)) in lorentzian
        .iter_mut()
        .zip(dispersive.iter_mut())
        .zip(&angles.map)
    {
        let (lv, dv) = if mirrored {
            (scratch.minus[base], scratch.dispersive_minus[base])
        } else {
            (scratch.plus[base], scratch.dispersive_plus[base])
        };
        *l += scale * lv;
        *d += scale * dv;
    }
}

/// The running sums of a block of `L` angles: G₁, H₁, G₂, H₂ (real and
/// imaginary parts, see the module docs).
#[derive(Clone, Copy)]
struct BlockSums<const L: usize> {
    g1r: [f64; L],
    g1i: [f64; L],
    h1r: [f64; L],
    h1i: [f64; L],
    g2r: [f64; L],
    g2i: [f64; L],
    h2r: [f64; L],
    h2i: [f64; L],
}

impl<const L: usize> BlockSums<L> {
    /// S1 and S2 at μ (`mirrored` false) or −μ of lane `j`.
    fn amplitudes(&self, j: usize, mirrored: bool) -> (Complex64, Complex64) {
        let sign = if mirrored { -1.0 } else { 1.0 };
        (
            Complex64::new(
                self.g1r[j] + sign * self.h1r[j],
                self.g1i[j] + sign * self.h1i[j],
            ),
            Complex64::new(
                self.g2r[j] + sign * self.h2r[j],
                self.g2i[j] + sign * self.h2i[j],
            ),
        )
    }
}

/// What a pass of the series does with each block's sums.
trait BlockOutput {
    /// Called once per block of `L` angles starting at base index `start`,
    /// with the sums and, for the stashed order, π_n and τ_n at μ.
    fn block<const L: usize>(
        &mut self,
        start: usize,
        sums: &BlockSums<L>,
        pi: &[f64; L],
        tau: &[f64; L],
    );
}

/// |S1|² + |S2|² at μ and at −μ.
struct IntensityOutput<'a> {
    plus: &'a mut [f64],
    minus: &'a mut [f64],
}

impl BlockOutput for IntensityOutput<'_> {
    #[inline(always)]
    fn block<const L: usize>(
        &mut self,
        start: usize,
        s: &BlockSums<L>,
        _: &[f64; L],
        _: &[f64; L],
    ) {
        for j in 0..L {
            let square = |re: f64, im: f64| re * re + im * im;
            self.plus[start + j] = square(s.g1r[j] + s.h1r[j], s.g1i[j] + s.h1i[j])
                + square(s.g2r[j] + s.h2r[j], s.g2i[j] + s.h2i[j]);
            self.minus[start + j] = square(s.g1r[j] - s.h1r[j], s.g1i[j] - s.h1i[j])
                + square(s.g2r[j] - s.h2r[j], s.g2i[j] - s.h2i[j]);
        }
    }
}

/// L and D of a resonance (see [`accumulate_resonance`]) at μ and −μ.
struct ResonanceOutput<'a> {
    order: usize,
    which: Coefficient,
    /// λ.
    damping: f64,
    /// L(μ), L(−μ), D(μ), D(−μ).
    out: [&'a mut [f64]; 4],
}

impl BlockOutput for ResonanceOutput<'_> {
    fn block<const L: usize>(
        &mut self,
        start: usize,
        sums: &BlockSums<L>,
        pi: &[f64; L],
        tau: &[f64; L],
    ) {
        let n = self.order as f64;
        let weight = (2.0 * n + 1.0) / (n * (n + 1.0));
        // π_n(−μ) = (−1)^{n−1} π_n(μ), τ_n(−μ) = (−1)^n τ_n(μ).
        let pi_sign = if self.order % 2 == 1 { 1.0 } else { -1.0 };
        for j in 0..L {
            for (mirrored, l_out, d_out) in [(false, 0, 2), (true, 1, 3)] {
                let (pi, tau) = if mirrored {
                    (pi_sign * pi[j], -pi_sign * tau[j])
                } else {
                    (pi[j], tau[j])
                };
                let (p1, p2) = match self.which {
                    Coefficient::A => (weight * pi, weight * tau),
                    Coefficient::B => (weight * tau, weight * pi),
                };
                let (s1, s2) = sums.amplitudes(j, mirrored);
                let lambda = self.damping;
                self.out[l_out][start + j] =
                    lambda * (lambda * (p1 * p1 + p2 * p2) + 2.0 * (p1 * s1.re + p2 * s2.re));
                self.out[d_out][start + j] = 2.0 * lambda * (p1 * s1.im + p2 * s2.im);
            }
        }
    }
}

/// |S1|² + |S2|² at the base cosines and their mirrors.
fn intensity_sums(terms: &[Term], mu: &[f64], plus: &mut [f64], minus: &mut [f64]) {
    series(terms, mu, 0, &mut IntensityOutput { plus, minus });
}

/// L and D of a resonance at the base cosines and their mirrors.
fn resonance_sums(
    terms: &[Term],
    mu: &[f64],
    order: usize,
    which: Coefficient,
    damping: f64,
    out: [&mut [f64]; 4],
) {
    series(
        terms,
        mu,
        order,
        &mut ResonanceOutput {
            order,
            which,
            damping,
            out,
        },
    );
}

/// Runs the series over every block of `mu` with the widest vector code
/// the processor runs; `stash` is the order whose π_n, τ_n the output gets
/// (0 for none). The only unsafe code of the workspace: calling a function
/// compiled for instructions the baseline target lacks, after checking that
/// the processor has them.
#[allow(unsafe_code)]
fn series<O: BlockOutput>(terms: &[Term], mu: &[f64], stash: usize, output: &mut O) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the processor supports AVX-512F, checked just above.
            unsafe { series_avx512(terms, mu, stash, output) };
            return;
        }
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the processor supports AVX2 and FMA, checked just above.
            unsafe { series_avx2(terms, mu, stash, output) };
            return;
        }
    }
    series_blocks::<8, false, O>(terms, mu, stash, output);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
fn series_avx512<O: BlockOutput>(terms: &[Term], mu: &[f64], stash: usize, output: &mut O) {
    series_blocks::<16, true, O>(terms, mu, stash, output);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn series_avx2<O: BlockOutput>(terms: &[Term], mu: &[f64], stash: usize, output: &mut O) {
    series_blocks::<8, true, O>(terms, mu, stash, output);
}

/// The recurrence state of a block: π_{n−1} and π_n for the next order.
struct Recurrence<const L: usize> {
    mu: [f64; L],
    pi_prev: [f64; L],
    pi: [f64; L],
}

/// Adds one (odd, even) pair of orders to the sums and advances the
/// recurrence; returns π and τ of the odd and of the even order.
#[inline(always)]
#[allow(clippy::type_complexity)]
fn pair_step<const L: usize, const FUSED: bool>(
    state: &mut Recurrence<L>,
    s: &mut BlockSums<L>,
    odd: &Term,
    even: &Term,
) -> ([f64; L], [f64; L], [f64; L], [f64; L]) {
    // a·b + c.
    let madd = |a: f64, b: f64, c: f64| if FUSED { a.mul_add(b, c) } else { a * b + c };
    let mut out = ([0.0; L], [0.0; L], [0.0; L], [0.0; L]);
    for j in 0..L {
        // τ_n = n μ π_n − (n + 1) π_{n−1} and
        // π_{n+1} = ((n + 1) μ π_n + τ_n) / n (BH eq. 4.47 rearranged).
        let (p, pp) = (state.pi[j], state.pi_prev[j]);
        let m = state.mu[j] * p;
        let tau = madd(odd.n, m, -odd.c3 * pp);
        s.g1r[j] = madd(odd.ar, p, s.g1r[j]);
        s.g1i[j] = madd(odd.ai, p, s.g1i[j]);
        s.h1r[j] = madd(odd.br, tau, s.h1r[j]);
        s.h1i[j] = madd(odd.bi, tau, s.h1i[j]);
        s.g2r[j] = madd(odd.br, p, s.g2r[j]);
        s.g2i[j] = madd(odd.bi, p, s.g2i[j]);
        s.h2r[j] = madd(odd.ar, tau, s.h2r[j]);
        s.h2i[j] = madd(odd.ai, tau, s.h2i[j]);
        (out.0[j], out.1[j]) = (p, tau);
        let p_next = madd(odd.c2, m, tau * odd.inv_n);
        // The even order that follows.
        let (p, pp) = (p_next, p);
        let m = state.mu[j] * p;
        let tau = madd(even.n, m, -even.c3 * pp);
        s.g1r[j] = madd(even.br, tau, s.g1r[j]);
        s.g1i[j] = madd(even.bi, tau, s.g1i[j]);
        s.h1r[j] = madd(even.ar, p, s.h1r[j]);
        s.h1i[j] = madd(even.ai, p, s.h1i[j]);
        s.g2r[j] = madd(even.ar, tau, s.g2r[j]);
        s.g2i[j] = madd(even.ai, tau, s.g2i[j]);
        s.h2r[j] = madd(even.br, p, s.h2r[j]);
        s.h2i[j] = madd(even.bi, p, s.h2i[j]);
        (out.2[j], out.3[j]) = (p, tau);
        state.pi_prev[j] = p;
        state.pi[j] = madd(even.c2, m, tau * even.inv_n);
    }
    out
}

/// The series for blocks of `L` angles (`mu.len()` a multiple of `L`), with
/// fused multiply–adds where `FUSED` (only where the processor has them:
/// elsewhere `mul_add` is a slow library call). The pairs before and after
/// the stashed order run without keeping π and τ.
#[inline(always)]
fn series_blocks<const L: usize, const FUSED: bool, O: BlockOutput>(
    terms: &[Term],
    mu: &[f64],
    stash: usize,
    output: &mut O,
) {
    // The pairs before the one holding the stashed order, that pair, and
    // the rest (all in `before` when `stash` is 0).
    let stash_pair = stash.checked_sub(1).map_or(terms.len() / 2, |i| i / 2);
    let (before, rest) = terms.split_at((2 * stash_pair).min(terms.len()));
    for (block, mu) in mu.chunks_exact(L).enumerate() {
        let mut state = Recurrence {
            mu: mu.try_into().expect("whole block"),
            pi_prev: [0.0; L],
            pi: [1.0; L],
        };
        let mut sums = BlockSums {
            g1r: [0.0; L],
            g1i: [0.0; L],
            h1r: [0.0; L],
            h1i: [0.0; L],
            g2r: [0.0; L],
            g2i: [0.0; L],
            h2r: [0.0; L],
            h2i: [0.0; L],
        };
        let (mut pi, mut tau) = ([0.0; L], [0.0; L]);
        for pair in before.chunks_exact(2) {
            pair_step::<L, FUSED>(&mut state, &mut sums, &pair[0], &pair[1]);
        }
        if let [odd, even, after @ ..] = rest {
            let (pi_odd, tau_odd, pi_even, tau_even) =
                pair_step::<L, FUSED>(&mut state, &mut sums, odd, even);
            (pi, tau) = if stash % 2 == 1 {
                (pi_odd, tau_odd)
            } else {
                (pi_even, tau_even)
            };
            for pair in after.chunks_exact(2) {
                pair_step::<L, FUSED>(&mut state, &mut sums, &pair[0], &pair[1]);
            }
        }
        output.block(block * L, &sums, &pi, &tau);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::mie::MieCoefficients;

    /// The mirrored block sums equal the plain recurrence of Bohren & Huffman
    /// at every angle, on both sides of 90°, for odd and even series lengths.
    #[test]
    fn mirrored_sums_match_the_direct_series() {
        for (x, m) in [
            (3.0, Complex64::new(1.33, 1e-8)),
            (62.0, Complex64::new(1.5, 0.1)),
            (417.3, Complex64::new(1.3314, 2e-8)),
        ] {
            let c = MieCoefficients::new(x, m);
            let angles_deg: Vec<f64> = (0..=1800).map(|i| i as f64 * 0.1).chain([33.3]).collect();
            let mu: Vec<f64> = angles_deg.iter().map(|a| a.to_radians().cos()).collect();
            let prepared = MirroredAngles::new(&mu);
            assert!(prepared.distinct() <= 902, "{}", prepared.distinct());
            let mut out = vec![0.0; mu.len()];
            accumulate_intensity(
                &c.a,
                &c.b,
                &prepared,
                2.0,
                &mut IntensityScratch::default(),
                &mut out,
            );
            for (i, (s1, s2)) in c.amplitudes(&mu).iter().enumerate() {
                let direct = 2.0 * (s1.norm_sqr() + s2.norm_sqr());
                let relative = (out[i] - direct).abs() / direct;
                assert!(
                    relative < 1e-9,
                    "x {x} θ {}: {} vs {direct}",
                    angles_deg[i],
                    out[i]
                );
            }
        }
    }

    /// L and D of a resonance reproduce the intensity for any value
    /// λ/(1 − it) of the resonant coefficient, on both sides of 90°.
    #[test]
    fn resonance_parts_give_the_intensity_along_the_resonance() {
        let c = MieCoefficients::new(57.3, Complex64::new(1.3314, 0.0));
        let angles_deg: Vec<f64> = (0..=360).map(|i| i as f64 * 0.5).collect();
        let mu: Vec<f64> = angles_deg.iter().map(|a| a.to_radians().cos()).collect();
        let prepared = MirroredAngles::new(&mu);
        for (order, which) in [
            (61, Coefficient::A),
            (58, Coefficient::B),
            (1, Coefficient::A),
            (2, Coefficient::B),
        ] {
            let (mut l, mut d) = (vec![0.0; mu.len()], vec![0.0; mu.len()]);
            let mut scratch = IntensityScratch::default();
            let lambda = 0.8;
            accumulate_resonance(
                &c.a,
                &c.b,
                order,
                which,
                lambda,
                &prepared,
                1.0,
                &mut scratch,
                &mut l,
                &mut d,
            );
            for t in [-30.0, -1.0, 0.0, 0.4, 7.0] {
                let value = lambda / Complex64::new(1.0, -t);
                let mut changed = c.clone();
                let mut emptied = c.clone();
                match which {
                    Coefficient::A => {
                        changed.a[order - 1] = value;
                        emptied.a[order - 1] = Complex64::new(0.0, 0.0);
                    }
                    Coefficient::B => {
                        changed.b[order - 1] = value;
                        emptied.b[order - 1] = Complex64::new(0.0, 0.0);
                    }
                }
                let full = changed.amplitudes(&mu);
                let base = emptied.amplitudes(&mu);
                for i in 0..mu.len() {
                    let intensity =
                        |(s1, s2): (Complex64, Complex64)| s1.norm_sqr() + s2.norm_sqr();
                    let expected = intensity(full[i]);
                    let model = intensity(base[i]) + (l[i] + d[i] * t) / (1.0 + t * t);
                    assert!(
                        (model - expected).abs() <= 1e-9 * expected.max(intensity(base[i])),
                        "n {order} {which:?} t {t} θ {}: {model} vs {expected}",
                        angles_deg[i]
                    );
                }
            }
        }
    }
}
