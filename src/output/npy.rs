//! Minimal `.npy` writers (NumPy format v1, little-endian, C order) on top of `npyz`.

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use anyhow::{Context, Result, bail};
use npyz::WriterBuilder;

/// Writes `data` (row-major, `shape.iter().product()` elements) as an `.npy` file.
fn write_npy<T: npyz::AutoSerialize + Copy>(
    path: &Path,
    shape: &[usize],
    data: &[T],
) -> Result<()> {
    let n: usize = shape.iter().product();
    if n != data.len() {
        bail!(
            "npy {}: shape {shape:?} needs {n} elements, got {}",
            path.display(),
            data.len()
        );
    }
    let file = File::create(path).with_context(|| format!("creating {}", path.display()))?;
    let shape64: Vec<u64> = shape.iter().map(|&s| s as u64).collect();
    let mut w = npyz::WriteOptions::new()
        .default_dtype()
        .shape(&shape64)
        .writer(BufWriter::new(file))
        .begin_nd()?;
    w.extend(data.iter().copied())?;
    w.finish()?;
    Ok(())
}

/// Writes a float64 array of the given `shape` (row-major data) to `path`.
pub fn write_npy_f64(path: &Path, shape: &[usize], data_row_major: &[f64]) -> Result<()> {
    write_npy(path, shape, data_row_major)
}

/// Writes a float32 array of the given `shape` (row-major data) to `path`.
pub fn write_npy_f32(path: &Path, shape: &[usize], data_row_major: &[f32]) -> Result<()> {
    write_npy(path, shape, data_row_major)
}

/// Writes a uint8 array (e.g. masks/flags) of the given `shape` to `path`.
pub fn write_npy_u8(path: &Path, shape: &[usize], data_row_major: &[u8]) -> Result<()> {
    write_npy(path, shape, data_row_major)
}

/// Writes an int32 array (e.g. labels/counts) of the given `shape` to `path`.
pub fn write_npy_i32(path: &Path, shape: &[usize], data_row_major: &[i32]) -> Result<()> {
    write_npy(path, shape, data_row_major)
}
