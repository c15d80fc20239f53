//! Lanes: the number type the chain solve and the fixed-step integrators are written over, so
//! that one source serves a single instance (`f64`, `f32`) and a vector of instances
//! integrated side by side ([`F64x4`]: 4 instances in `f64`, [`F32x8`]: 8 in `f32`, one AVX
//! register each; the `wide` crate maps them onto SSE2 pairs where AVX is not compiled in;
//! [`F64x8`] and [`F32x16`], one AVX-512 register each, which the CPU engine takes where the
//! build targets AVX-512: [`F64Lanes`], [`F32Lanes`]).
//!
//! Every operation is lane-wise and the same IEEE operation as the scalar code, in the same
//! order, so a lane of a vector computes what the scalar engine computes, except for `sin` and
//! `cos`: the vectors use `wide`'s polynomial (Agner Fog's vector class library, within a few
//! ulp), the scalars the platform's libm. Branches of the physics (a bumper pushing or not)
//! become lane selects ([`Lane::if_positive`]).
//!
//! [`Real`] is the scalar alone (`f64` for the reference and the CPU fallback, `f32` for what the
//! GPU computes, so that its error can be measured on the CPU); each scalar is a lane of one.

use std::fmt::Debug;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// 4 `f64` lanes.
pub type F64x4 = wide::f64x4;
/// 8 `f32` lanes.
pub type F32x8 = wide::f32x8;
/// 16 `f32` lanes (one AVX-512 register where AVX-512 is compiled in).
pub type F32x16 = wide::f32x16;
/// 8 `f64` lanes (one AVX-512 register where AVX-512 is compiled in).
pub type F64x8 = wide::f64x8;

/// The CPU engine's vectors where the build targets AVX-512: one 512-bit register each.
#[cfg(target_feature = "avx512f")]
mod widest {
    /// The CPU engine's `f64` vector.
    pub type F64Lanes = super::F64x8;
    /// The CPU engine's `f32` vector.
    pub type F32Lanes = super::F32x16;
}

/// The CPU engine's vectors elsewhere: one AVX register each (two SSE2 registers without AVX;
/// a 512-bit type would cost two of these per operation without AVX-512).
#[cfg(not(target_feature = "avx512f"))]
mod widest {
    /// The CPU engine's `f64` vector.
    pub type F64Lanes = super::F64x4;
    /// The CPU engine's `f32` vector.
    pub type F32Lanes = super::F32x8;
}

pub use widest::{F32Lanes, F64Lanes};

/// A number, or a vector of numbers of independent instances, that the chain solve runs on.
pub trait Lane:
    Copy
    + Send
    + Sync
    + Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + 'static
{
    /// The float type of one lane.
    type Scalar: Real;
    /// Instances per value.
    const LANES: usize;
    /// Every lane `x` (rounded to the lane type).
    fn splat(x: f64) -> Self;
    /// Lane `i` is `f(i)` (rounded to the lane type).
    fn gather(f: impl FnMut(usize) -> f64) -> Self;
    /// Lane `i`.
    fn lane(self, i: usize) -> Self::Scalar;
    /// This value with lane `i` replaced by `v`.
    fn with_lane(self, i: usize, v: Self::Scalar) -> Self;
    /// Lane-wise (sin x, cos x).
    fn v_sin_cos(self) -> (Self, Self);
    /// Lane-wise max(x, y); a NaN lane of `y` gives x, as `f64::max`.
    fn v_max(self, y: Self) -> Self;
    /// Lane-wise `if cond > 0 { a } else { b }`.
    fn if_positive(cond: Self, a: Self, b: Self) -> Self;
    /// This value, where a compiler may not see through it. A compensated sum's
    /// `(s − y) − c` with `s = y + c` is 0 to a compiler that reassociates floats, as GPU
    /// shader compilers may (lavapipe does): the kernels write `s` there as `s · ctl.one`, a 1
    /// known only at run time. Native code keeps IEEE order, so the value is itself.
    #[inline(always)]
    fn opaque(self) -> Self {
        self
    }
}

macro_rules! scalar_lane {
    ($t:ty) => {
        impl Lane for $t {
            type Scalar = $t;
            const LANES: usize = 1;
            #[inline(always)]
            fn splat(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn gather(mut f: impl FnMut(usize) -> f64) -> Self {
                f(0) as $t
            }
            #[inline(always)]
            fn lane(self, _: usize) -> $t {
                self
            }
            #[inline(always)]
            fn with_lane(self, _: usize, v: $t) -> Self {
                v
            }
            #[inline(always)]
            fn v_sin_cos(self) -> (Self, Self) {
                self.sin_cos()
            }
            #[inline(always)]
            fn v_max(self, y: Self) -> Self {
                self.max(y)
            }
            #[inline(always)]
            fn if_positive(cond: Self, a: Self, b: Self) -> Self {
                if cond > 0.0 { a } else { b }
            }
        }
    };
}

scalar_lane!(f64);
scalar_lane!(f32);

macro_rules! vector_lane {
    ($v:ty, $t:ty, $n:expr) => {
        impl Lane for $v {
            type Scalar = $t;
            const LANES: usize = $n;
            #[inline(always)]
            fn splat(x: f64) -> Self {
                <$v>::splat(x as $t)
            }
            #[inline(always)]
            fn gather(mut f: impl FnMut(usize) -> f64) -> Self {
                <$v>::new(std::array::from_fn(|i| f(i) as $t))
            }
            #[inline(always)]
            fn lane(self, i: usize) -> $t {
                self.as_array()[i]
            }
            #[inline]
            fn with_lane(self, i: usize, v: $t) -> Self {
                let mut a = self.to_array();
                a[i] = v;
                <$v>::new(a)
            }
            #[inline(always)]
            fn v_sin_cos(self) -> (Self, Self) {
                self.sin_cos()
            }
            #[inline(always)]
            fn v_max(self, y: Self) -> Self {
                // `wide`'s max picks the other operand where one is NaN, as f64::max does.
                self.max(y)
            }
            #[inline(always)]
            fn if_positive(cond: Self, a: Self, b: Self) -> Self {
                cond.simd_gt(<$v>::splat(0.0)).select(a, b)
            }
        }
    };
}

vector_lane!(F64x4, f64, 4);
vector_lane!(F32x8, f32, 8);
vector_lane!(F32x16, f32, 16);
vector_lane!(F64x8, f64, 8);

/// A floating-point scalar usable by the chain solve and the RK4 engine.
pub trait Real:
    Lane<Scalar = Self>
    + num_traits::Float
    + num_traits::FloatConst
    + Default
    + Send
    + Sync
    + std::fmt::Debug
    + std::fmt::Display
    + std::ops::AddAssign
    + std::ops::SubAssign
    + std::ops::MulAssign
    + 'static
{
    /// Convert from `f64` (rounding to nearest for `f32`).
    fn of(x: f64) -> Self;
    /// Widen to `f64`.
    fn wide(self) -> f64;
    /// A short name for reports ("f32" or "f64").
    const NAME: &'static str;
}

impl Real for f64 {
    #[inline(always)]
    fn of(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn wide(self) -> f64 {
        self
    }
    const NAME: &'static str = "f64";
}

impl Real for f32 {
    #[inline(always)]
    fn of(x: f64) -> Self {
        x as f32
    }
    #[inline(always)]
    fn wide(self) -> f64 {
        self as f64
    }
    const NAME: &'static str = "f32";
}
