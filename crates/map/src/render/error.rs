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

impl<E: std::error::Error + Send + Sync + 'static> From<plotters::drawing::DrawingAreaErrorKind<E>>
    for RenderError
{
    fn from(e: plotters::drawing::DrawingAreaErrorKind<E>) -> Self {
        use plotters::drawing::DrawingAreaErrorKind as Area;
        use plotters_backend::DrawingErrorKind as Backend;
        RenderError::Draw(match &e {
            Area::BackendError(Backend::DrawingError(inner)) => backend_text(inner),
            Area::BackendError(Backend::FontError(f)) => format!("font: {f}"),
            other => other.to_string(),
        })
    }
}

/// The reason of a bitmap backend's error in words (its own `Display` prints its `Debug`
/// form, `ImageError(IoError(Custom { .. }))`).
fn backend_text<E: std::error::Error + 'static>(inner: &E) -> String {
    use plotters_bitmap::BitMapBackendError as Bitmap;
    match (inner as &dyn std::any::Any).downcast_ref::<Bitmap>() {
        Some(Bitmap::IOError(io)) => io.to_string(),
        Some(Bitmap::ImageError(img)) => img.to_string(),
        Some(Bitmap::InvalidBuffer) => "the pixel buffer has the wrong size".into(),
        _ => inner.to_string(),
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
