//! A value with its gradient in space (forward-mode differentiation), so
//! that the blob field and its normal come out of one evaluation, exactly.

use glam::DVec3;
use std::ops::{Add, Mul, Neg, Sub};

/// f(P) and ∇f(P).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual {
    /// The value.
    pub value: f64,
    /// Its gradient with respect to the position, per metre.
    pub gradient: DVec3,
}

impl Dual {
    /// A constant.
    pub const fn constant(value: f64) -> Self {
        Self {
            value,
            gradient: DVec3::ZERO,
        }
    }

    /// e^f.
    pub fn exp(self) -> Self {
        let e = self.value.exp();
        Self {
            value: e,
            gradient: self.gradient * e,
        }
    }

    /// ln f (f > 0).
    pub fn ln(self) -> Self {
        Self {
            value: self.value.ln(),
            gradient: self.gradient / self.value,
        }
    }

    /// 1 / f (f ≠ 0).
    pub fn recip(self) -> Self {
        let r = 1.0 / self.value;
        Self {
            value: r,
            gradient: -self.gradient * (r * r),
        }
    }

    /// The larger of two values, with the gradient of the one taken.
    pub fn max(self, other: Self) -> Self {
        if other.value > self.value {
            other
        } else {
            self
        }
    }

    /// The smaller of two values, with the gradient of the one taken.
    pub fn min(self, other: Self) -> Self {
        if other.value < self.value {
            other
        } else {
            self
        }
    }

    /// f · s for a constant s.
    pub fn scale(self, s: f64) -> Self {
        Self {
            value: self.value * s,
            gradient: self.gradient * s,
        }
    }
}

impl Add for Dual {
    type Output = Dual;
    fn add(self, o: Dual) -> Dual {
        Dual {
            value: self.value + o.value,
            gradient: self.gradient + o.gradient,
        }
    }
}

impl Sub for Dual {
    type Output = Dual;
    fn sub(self, o: Dual) -> Dual {
        Dual {
            value: self.value - o.value,
            gradient: self.gradient - o.gradient,
        }
    }
}

impl Mul for Dual {
    type Output = Dual;
    fn mul(self, o: Dual) -> Dual {
        Dual {
            value: self.value * o.value,
            gradient: self.gradient * o.value + o.gradient * self.value,
        }
    }
}

impl Neg for Dual {
    type Output = Dual;
    fn neg(self) -> Dual {
        self.scale(-1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The chain rule against central differences on a composite function.
    #[test]
    fn gradients_match_finite_differences() {
        let f = |p: DVec3| {
            let x = Dual {
                value: p.x,
                gradient: DVec3::X,
            };
            let y = Dual {
                value: p.y,
                gradient: DVec3::Y,
            };
            let z = Dual {
                value: p.z,
                gradient: DVec3::Z,
            };
            ((x * y).exp() + (z * z + Dual::constant(1.0)).ln() - x.recip()).scale(0.5)
        };
        let p = DVec3::new(0.7, -0.3, 1.2);
        let g = f(p).gradient;
        let h = 1e-6;
        for (axis, component) in [(DVec3::X, g.x), (DVec3::Y, g.y), (DVec3::Z, g.z)] {
            let numeric = (f(p + axis * h).value - f(p - axis * h).value) / (2.0 * h);
            assert!(
                (numeric - component).abs() < 1e-7,
                "{numeric} vs {component}"
            );
        }
    }
}
