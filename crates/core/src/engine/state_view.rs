//! How the step loop's bookkeeping sees a state: one instance's slice `[θ; θ̇; v]` of the
//! single runs, or one lane of the CPU engine's state of vectors. The loop ([`super::stepper`]),
//! λ1's twin ([`super::twin`]) and the early stop read states only through these.

/// A state the bookkeeping reads: one instance's slice `[θ; θ̇; v]`, or one lane of a state
/// of vectors.
pub(crate) trait StateView<T> {
    /// Component `k`.
    fn at(&self, k: usize) -> T;
    /// Components.
    fn len(&self) -> usize;
}

/// A state the bookkeeping also writes (the twin of λ1, renormalised).
pub(crate) trait StateViewMut<T>: StateView<T> {
    /// Set component `k`.
    fn set(&mut self, k: usize, v: T);
}

impl<T: Copy> StateView<T> for [T] {
    #[inline]
    fn at(&self, k: usize) -> T {
        self[k]
    }
    fn len(&self) -> usize {
        <[T]>::len(self)
    }
}

impl<T: Copy> StateViewMut<T> for [T] {
    #[inline]
    fn set(&mut self, k: usize, v: T) {
        self[k] = v;
    }
}
