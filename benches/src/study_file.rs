//! Reading a verdict study's `verdict.json` back (`verdict_report` writes it): for the fit
//! across planes and for the references a later study keeps.

use std::path::Path;

/// Why a study's `verdict.json` cannot be read back.
#[derive(Debug, thiserror::Error)]
pub enum StudyFileError {
    /// The file could not be read.
    #[error("cannot read `{path}`: {source}")]
    Read {
        /// The file.
        path: String,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// It lacks what the reader needs.
    #[error(
        "`{path}` is not a verdict study of this version ({reason}); run `pendulum-atlas-lab verdict --plane P --out DIR` again"
    )]
    Parse {
        /// The file.
        path: String,
        /// What is missing or wrong.
        reason: String,
    },
}

/// The part `T` of the study in `dir` (its `verdict.json`), and the file's path as shown.
pub fn read_study<T: serde::de::DeserializeOwned>(
    dir: &Path,
) -> Result<(T, String), StudyFileError> {
    let path = dir.join("verdict.json");
    let shown = path.display().to_string();
    let text = std::fs::read_to_string(&path).map_err(|source| StudyFileError::Read {
        path: shown.clone(),
        source,
    })?;
    match serde_json::from_str(&text) {
        Ok(t) => Ok((t, shown)),
        Err(e) => Err(StudyFileError::Parse {
            path: shown,
            reason: e.to_string(),
        }),
    }
}
