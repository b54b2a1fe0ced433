//! The number type of the contact laws: `f64` for one contact, or
//! [`Lanes`] for [`LANE_COUNT`] contacts at once. `Lanes` is a plain array
//! whose operations are lane-by-lane loops the compiler turns into vector
//! instructions, as wide as the function they are inlined into allows: two
//! lanes per instruction in a generic x86-64 build, four where the force
//! pass runs in its AVX2 copy (`dem::forces`). Only IEEE-exact operations
//! (+, −, ×, ÷, √, compare, select; no fused multiply–add) are used, so
//! every lane gets the bits the `f64` law gives, on any machine.

use std::fmt::Debug;
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// Number of contacts in [`Lanes`].
pub const LANE_COUNT: usize = 4;

/// What the contact laws compute with: arithmetic plus the few lane-wise
/// operations below. Implemented by `f64` and [`Lanes`].
pub trait Real:
    Copy
    + Debug
    + PartialEq
    + 'static
    + num_traits::Zero
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
{
    /// Per-lane truth values.
    type Mask: Copy;
    /// `v` in every lane.
    fn splat(v: f64) -> Self;
    /// Square root.
    fn simd_sqrt(self) -> Self;
    /// Absolute value.
    fn simd_abs(self) -> Self;
    /// `self > other`, per lane.
    fn simd_gt(self, other: Self) -> Self::Mask;
    /// `self` where `cond` holds, else `other`, per lane.
    fn select(self, cond: Self::Mask, other: Self) -> Self;
    /// Whether `cond` holds in any lane.
    fn any(cond: Self::Mask) -> bool;
}

impl Real for f64 {
    type Mask = bool;
    #[inline(always)]
    fn splat(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn simd_sqrt(self) -> Self {
        self.sqrt()
    }
    #[inline(always)]
    fn simd_abs(self) -> Self {
        self.abs()
    }
    #[inline(always)]
    fn simd_gt(self, other: Self) -> bool {
        self > other
    }
    #[inline(always)]
    fn select(self, cond: bool, other: Self) -> Self {
        if cond {
            self
        } else {
            other
        }
    }
    #[inline(always)]
    fn any(cond: bool) -> bool {
        cond
    }
}

/// [`LANE_COUNT`] contacts' values, one per lane.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub struct Lanes(pub [f64; LANE_COUNT]);

impl Lanes {
    #[inline(always)]
    fn zip(self, o: Lanes, f: impl Fn(f64, f64) -> f64) -> Lanes {
        Lanes(std::array::from_fn(|l| f(self.0[l], o.0[l])))
    }
}

macro_rules! lane_ops {
    ($($op:ident $fn:ident $aop:ident $afn:ident $sym:tt),*) => {$(
        impl $op for Lanes {
            type Output = Lanes;
            #[inline(always)]
            fn $fn(self, o: Lanes) -> Lanes {
                self.zip(o, |a, b| a $sym b)
            }
        }
        impl $aop for Lanes {
            #[inline(always)]
            fn $afn(&mut self, o: Lanes) {
                *self = self.zip(o, |a, b| a $sym b);
            }
        }
    )*};
}
lane_ops!(Add add AddAssign add_assign +, Sub sub SubAssign sub_assign -,
          Mul mul MulAssign mul_assign *, Div div DivAssign div_assign /);

impl Neg for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn neg(self) -> Lanes {
        Lanes(self.0.map(|a| -a))
    }
}

impl num_traits::Zero for Lanes {
    #[inline(always)]
    fn zero() -> Lanes {
        Lanes([0.0; LANE_COUNT])
    }
    fn is_zero(&self) -> bool {
        self.0.iter().all(|a| *a == 0.0)
    }
}

impl Real for Lanes {
    type Mask = [bool; LANE_COUNT];
    #[inline(always)]
    fn splat(v: f64) -> Self {
        Lanes([v; LANE_COUNT])
    }
    #[inline(always)]
    fn simd_sqrt(self) -> Self {
        Lanes(self.0.map(f64::sqrt))
    }
    #[inline(always)]
    fn simd_abs(self) -> Self {
        Lanes(self.0.map(f64::abs))
    }
    #[inline(always)]
    fn simd_gt(self, other: Self) -> Self::Mask {
        std::array::from_fn(|l| self.0[l] > other.0[l])
    }
    #[inline(always)]
    fn select(self, cond: Self::Mask, other: Self) -> Self {
        Lanes(std::array::from_fn(|l| {
            if cond[l] {
                self.0[l]
            } else {
                other.0[l]
            }
        }))
    }
    #[inline(always)]
    fn any(cond: Self::Mask) -> bool {
        cond.iter().any(|&c| c)
    }
}
