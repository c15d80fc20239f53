//! Writing a file so that it is either absent, as it was, or complete: every writer of the
//! crate goes through here. Content goes to a temporary sibling (`.NAME.tmp-PID.EXT`) that is
//! renamed over the target once complete, so a killed run never leaves a file that looks whole.

use super::error::OutputError;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// The temporary sibling of `target` (same folder, same extension, so that writers that pick a
/// format by extension, such as PNG encoders, still do).
pub(crate) fn temp_path(target: &Path) -> PathBuf {
    let name = target
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = target
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    target.with_file_name(format!(".{name}.tmp-{}{ext}", std::process::id()))
}

/// [`super::held::check_held`] on `target`'s folder.
fn check_folder(target: &Path) -> Result<(), OutputError> {
    match target.parent() {
        Some(dir) => super::held::check_held(dir),
        None => Ok(()),
    }
}

/// Create `dir` and its parents.
pub fn create_dir(dir: &Path) -> Result<(), OutputError> {
    std::fs::create_dir_all(dir).map_err(|e| OutputError::io(dir, e))
}

/// A file being written to its temporary sibling; [`AtomicFile::commit`] renames it over the
/// target, dropping it uncommitted removes it.
pub struct AtomicFile {
    target: PathBuf,
    tmp: PathBuf,
    out: Option<BufWriter<File>>,
}

impl AtomicFile {
    /// Start writing `target`.
    pub fn create(target: &Path) -> Result<AtomicFile, OutputError> {
        check_folder(target)?;
        let tmp = temp_path(target);
        let file = File::create(&tmp).map_err(|e| OutputError::io(target, e))?;
        Ok(AtomicFile {
            target: target.to_path_buf(),
            tmp,
            out: Some(BufWriter::new(file)),
        })
    }

    /// The file this will become.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Flush, then rename the temporary file over the target; on any error the temporary
    /// file is removed and the target left as it was.
    pub fn commit(mut self) -> Result<PathBuf, OutputError> {
        let out = self.out.take().expect("not yet committed");
        if let Err(e) = check_folder(&self.target) {
            drop(out);
            let _ = std::fs::remove_file(&self.tmp);
            return Err(e);
        }
        let done = out
            .into_inner()
            .map_err(|e| e.into_error())
            .and_then(|f| f.sync_all())
            .and_then(|()| std::fs::rename(&self.tmp, &self.target));
        if let Err(e) = done {
            let _ = std::fs::remove_file(&self.tmp);
            return Err(OutputError::io(&self.target, e));
        }
        Ok(self.target.clone())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.out.as_mut().expect("not yet committed").write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.out.as_mut().expect("not yet committed").flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.out.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Write `bytes` as the whole of `path`.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<PathBuf, OutputError> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes).map_err(|e| OutputError::io(path, e))?;
    f.commit()
}

/// Writes a TOML table under a comment `header` (each of its lines gets `# `).
pub fn write_toml(path: &Path, table: &toml::Table, header: &str) -> Result<PathBuf, OutputError> {
    let body = toml::to_string(table).map_err(|e| OutputError::Toml {
        path: path.display().to_string(),
        reason: e.to_string(),
    })?;
    let comment: String = header.lines().map(|l| format!("# {l}\n")).collect();
    write_bytes(path, format!("{comment}\n{body}").as_bytes())
}

/// Write a value as pretty-printed JSON.
pub fn write_json<T: serde::Serialize + ?Sized>(
    path: &Path,
    value: &T,
) -> Result<PathBuf, OutputError> {
    let text = serde_json::to_string_pretty(value).map_err(|source| OutputError::Json {
        path: path.display().to_string(),
        source,
    })?;
    write_bytes(path, text.as_bytes())
}

/// A CSV writer on a temporary file; finish it with [`commit_csv`].
pub fn create_csv(path: &Path) -> Result<csv::Writer<AtomicFile>, OutputError> {
    Ok(csv::Writer::from_writer(AtomicFile::create(path)?))
}

/// Flush a CSV writer and rename its file into place.
pub fn commit_csv(w: csv::Writer<AtomicFile>, path: &Path) -> Result<PathBuf, OutputError> {
    w.into_inner()
        .map_err(|e| OutputError::io(path, std::io::Error::other(e.to_string())))?
        .commit()
}

/// The error of a CSV write on `path`.
pub fn csv_error(path: &Path) -> impl Fn(csv::Error) -> OutputError + '_ {
    move |source| OutputError::Csv {
        path: path.display().to_string(),
        source,
    }
}

/// Draw a picture at `path` through its temporary sibling (the renderers write directly).
#[cfg(feature = "pictures")]
pub fn draw(
    path: &Path,
    render: impl FnOnce(&Path) -> Result<(), crate::render::RenderError>,
) -> Result<PathBuf, OutputError> {
    let tmp = temp_path(path);
    let drawn = render(&tmp).map_err(|source| OutputError::Render {
        path: path.display().to_string(),
        source,
    });
    if let Err(e) = drawn {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    if let Err(e) = std::fs::rename(&tmp, path) {
        let _ = std::fs::remove_file(&tmp);
        return Err(OutputError::io(path, e));
    }
    Ok(path.to_path_buf())
}
