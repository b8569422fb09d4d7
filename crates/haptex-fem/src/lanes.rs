//! Numbers for the finite-strain element loop: one f64, or [`LANES`] of
//! them side by side in a SIMD register ([`Lanes`], one element per lane).
//! The kinematics and the neo-Hookean law are written once, generic over
//! [`Real`]; on [`Lanes`] every operation is the f64 one lane by lane (IEEE
//! add, subtract, multiply, divide, negate; no fused multiply-add), so a
//! lane's result is the scalar one to the bit, and with AVX2 one
//! instruction does it for four elements
//! ([`crate::finite_element::ElementBlock`]).
//!
//! The SIMD level is chosen at run time by [`pulp::Arch`] (as faer does):
//! [`Lanes`] is generic over pulp's [`pulp::Simd`] and holds its token.

use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub};

use pulp::Simd;

/// Elements side by side: four f64, one AVX2 register.
pub const LANES: usize = 4;

/// A number of the element loop: f64 or [`Lanes`].
pub trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
{
    /// The constant `v` (in every lane), of the kind of `self`.
    fn constant(self, v: f64) -> Self;
    /// `f` applied lane by lane (for what is not arithmetic: bit tricks).
    fn map(self, f: impl Fn(f64) -> f64) -> Self;
}

impl Real for f64 {
    #[inline(always)]
    fn constant(self, v: f64) -> Self {
        v
    }

    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        f(self)
    }
}

/// [`LANES`] f64 in a SIMD register of `S` (which must have at least
/// [`LANES`] f64 lanes: [`Lanes::fits`]; lanes beyond [`LANES`] are
/// computed and ignored).
#[derive(Debug, Clone, Copy)]
pub struct Lanes<S: Simd> {
    v: S::f64s,
    simd: S,
}

impl<S: Simd> Lanes<S> {
    /// Whether `S`'s registers hold [`LANES`] f64.
    #[inline(always)]
    pub fn fits() -> bool {
        S::F64_LANES >= LANES
    }

    #[inline(always)]
    pub fn load(simd: S, x: &[f64; LANES]) -> Self {
        let v = match S::as_simd_f64s(x).0.first() {
            Some(&v) => v,
            None => simd.partial_load_f64s(x),
        };
        Self { v, simd }
    }

    #[inline(always)]
    pub fn splat(simd: S, x: f64) -> Self {
        Self { v: simd.splat_f64s(x), simd }
    }

    #[inline(always)]
    pub fn to_array(self) -> [f64; LANES] {
        let mut out = [0.0; LANES];
        match S::as_mut_simd_f64s(&mut out).0.first_mut() {
            Some(v) => *v = self.v,
            None => self.simd.partial_store_f64s(&mut out, self.v),
        }
        out
    }
}

impl<S: Simd> Real for Lanes<S> {
    #[inline(always)]
    fn constant(self, v: f64) -> Self {
        Self::splat(self.simd, v)
    }

    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        Self::load(self.simd, &self.to_array().map(f))
    }
}

macro_rules! lane_by_lane {
    ($trait:ident, $method:ident, $simd_method:ident) => {
        impl<S: Simd> $trait for Lanes<S> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, other: Self) -> Self {
                Self { v: self.simd.$simd_method(self.v, other.v), simd: self.simd }
            }
        }
    };
}

lane_by_lane!(Add, add, add_f64s);
lane_by_lane!(Sub, sub, sub_f64s);
lane_by_lane!(Mul, mul, mul_f64s);
lane_by_lane!(Div, div, div_f64s);

impl<S: Simd> Neg for Lanes<S> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self { v: self.simd.neg_f64s(self.v), simd: self.simd }
    }
}

impl<S: Simd> AddAssign for Lanes<S> {
    #[inline(always)]
    fn add_assign(&mut self, other: Self) {
        *self = *self + other;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Check;

    impl pulp::WithSimd for Check {
        type Output = ();

        #[inline(always)]
        fn with_simd<S: Simd>(self, simd: S) {
            if !Lanes::<S>::fits() {
                return;
            }
            let (x, y) = ([1.5, -2.0, 3.25, 1e-300], [0.1, 7.0, -0.5, 1e10]);
            let (a, b) = (Lanes::load(simd, &x), Lanes::load(simd, &y));
            let bits = |v: Lanes<S>| v.to_array().map(f64::to_bits);
            for l in 0..LANES {
                assert_eq!(bits(a + b)[l], (x[l] + y[l]).to_bits());
                assert_eq!(bits(a - b)[l], (x[l] - y[l]).to_bits());
                assert_eq!(bits(a * b)[l], (x[l] * y[l]).to_bits());
                assert_eq!(bits(a / b)[l], (x[l] / y[l]).to_bits());
                assert_eq!(bits(-a)[l], (-x[l]).to_bits());
                assert_eq!(bits(a.map(|v| v * 3.0))[l], (x[l] * 3.0).to_bits());
                assert_eq!(bits(a.constant(2.5))[l], 2.5f64.to_bits());
            }
        }
    }

    #[test]
    fn lanes_are_the_f64_operations_lane_by_lane() {
        pulp::Arch::new().dispatch(Check);
    }
}
