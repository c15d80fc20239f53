//! The floating-point type the engine is generic over: `f64` for the reference and the CPU
//! fallback, `f32` for what the GPU computes (so its error can be measured on the CPU).

/// A floating-point scalar usable by the chain solve and the RK4 engine.
pub trait Real:
    crate::model::lane::Lane<Scalar = Self>
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
