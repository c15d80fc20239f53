//! Minimal `.npy` writers (NumPy format v1, little-endian, C order) on top of `npyz`, written
//! through a temporary file like every output.

use super::error::OutputError;
use super::files::AtomicFile;
use npyz::WriterBuilder;
use std::path::Path;

/// Writes `data` (row-major, `shape.iter().product()` elements) as an `.npy` file.
fn write_npy<T: npyz::AutoSerialize + Copy>(
    path: &Path,
    shape: &[usize],
    data: &[T],
) -> Result<(), OutputError> {
    let fail = |reason: String| OutputError::Npy {
        path: path.display().to_string(),
        reason,
    };
    let n: usize = shape.iter().product();
    if n != data.len() {
        return Err(fail(format!(
            "shape {shape:?} needs {n} elements, got {}",
            data.len()
        )));
    }
    let mut file = AtomicFile::create(path)?;
    let shape64: Vec<u64> = shape.iter().map(|&s| s as u64).collect();
    let mut w = npyz::WriteOptions::new()
        .default_dtype()
        .shape(&shape64)
        .writer(&mut file)
        .begin_nd()
        .map_err(|e| fail(e.to_string()))?;
    w.extend(data.iter().copied())
        .map_err(|e| fail(e.to_string()))?;
    w.finish().map_err(|e| fail(e.to_string()))?;
    file.commit()?;
    Ok(())
}

/// Writes a float64 array of the given `shape` (row-major data) to `path`.
pub fn write_npy_f64(
    path: &Path,
    shape: &[usize],
    data_row_major: &[f64],
) -> Result<(), OutputError> {
    write_npy(path, shape, data_row_major)
}

/// Writes a float32 array of the given `shape` (row-major data) to `path`.
pub fn write_npy_f32(
    path: &Path,
    shape: &[usize],
    data_row_major: &[f32],
) -> Result<(), OutputError> {
    write_npy(path, shape, data_row_major)
}

/// Writes a uint8 array (e.g. masks/flags) of the given `shape` to `path`.
pub fn write_npy_u8(
    path: &Path,
    shape: &[usize],
    data_row_major: &[u8],
) -> Result<(), OutputError> {
    write_npy(path, shape, data_row_major)
}

/// Writes an int8 array (e.g. category codes) of the given `shape` to `path`. Only the map's
/// folder writer, behind the `pictures` feature, writes one.
#[cfg(feature = "pictures")]
pub(crate) fn write_npy_i8(
    path: &Path,
    shape: &[usize],
    data_row_major: &[i8],
) -> Result<(), OutputError> {
    write_npy(path, shape, data_row_major)
}

/// Writes an int32 array (e.g. labels/counts) of the given `shape` to `path`.
pub fn write_npy_i32(
    path: &Path,
    shape: &[usize],
    data_row_major: &[i32],
) -> Result<(), OutputError> {
    write_npy(path, shape, data_row_major)
}

/// A NumPy dtype in a user's words, for Rust's element type name `rust`.
fn npy_dtype_words(rust: &str) -> &'static str {
    match rust {
        "f64" => "float64",
        "f32" => "float32",
        "i8" => "int8",
        "u8" => "uint8",
        "i32" => "int32",
        "u32" => "uint32",
        "i64" => "int64",
        "u64" => "uint64",
        _ => "another dtype",
    }
}

/// Reads an `.npy` array of `T` (`f64`, `u8`, ...): its shape and its elements in C order.
/// The error names the file and says what is wrong with it.
pub fn read_npy<T: npyz::Deserialize>(path: &Path) -> Result<(Vec<usize>, Vec<T>), String> {
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {name}: {e}"))?;
    let npy = npyz::NpyFile::new(&bytes[..]).map_err(|e| format!("{name}: {e}"))?;
    let shape = npy.shape().iter().map(|&s| s as usize).collect();
    let data = npy.into_vec::<T>().map_err(|_| {
        format!(
            "{name}: its values are not of the type this program writes there ({}): the file is damaged or from another program",
            npy_dtype_words(std::any::type_name::<T>())
        )
    })?;
    Ok((shape, data))
}
