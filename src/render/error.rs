//! What can go wrong while drawing a picture.

use thiserror::Error;

/// Errors of the renderers: bad input data, or the drawing backend failing.
#[derive(Debug, Error)]
pub enum RenderError {
    /// The data cannot be drawn as given (mismatched lengths, non-monotonic axes, ...).
    #[error("{0}")]
    Input(String),
    /// plotters failed while drawing or writing the bitmap.
    #[error("drawing failed: {0}")]
    Draw(String),
    /// The embedded font could not be registered.
    #[error("the embedded font DejaVuSans.ttf could not be parsed")]
    Font,
}

impl<E: std::error::Error + Send + Sync> From<plotters::drawing::DrawingAreaErrorKind<E>>
    for RenderError
{
    fn from(e: plotters::drawing::DrawingAreaErrorKind<E>) -> Self {
        RenderError::Draw(e.to_string())
    }
}

/// The result of a renderer.
pub type Result<T> = std::result::Result<T, RenderError>;

/// Return early with [`RenderError::Input`].
macro_rules! bad_input {
    ($($arg:tt)*) => {
        return Err($crate::render::RenderError::Input(format!($($arg)*)))
    };
}
pub(crate) use bad_input;
