//! What can go wrong while writing results: every variant names the file.

use thiserror::Error;

/// Errors of the output writers.
#[derive(Debug, Error)]
pub enum OutputError {
    /// A file or folder could not be created, written or renamed.
    #[error("cannot write `{path}`: {source}")]
    Io {
        /// The file or folder.
        path: String,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// A CSV writer failed.
    #[error("cannot write `{path}`: {source}")]
    Csv {
        /// The file.
        path: String,
        /// The CSV writer's reason.
        source: csv::Error,
    },
    /// A `.npy` array does not match its shape, or its writer failed.
    #[error("cannot write `{path}`: {reason}")]
    Npy {
        /// The file.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// A TOML document could not be serialised.
    #[error("cannot write `{path}`: {reason}")]
    Toml {
        /// The file.
        path: String,
        /// The serialiser's reason.
        reason: String,
    },
    /// A JSON document could not be serialised.
    #[error("cannot write `{path}`: {source}")]
    Json {
        /// The file.
        path: String,
        /// serde_json's reason.
        source: serde_json::Error,
    },
    /// The folder in which `--force` sets an earlier run aside holds what this tool did not
    /// put there (a symlink, a folder, another file): refused, and nothing is moved.
    #[error(
        "`{path}` is {what}, where pendulum-atlas keeps an earlier run's files while it replaces them; it did not make it: nothing was moved. Remove it (after checking what it holds), or choose another --out"
    )]
    PlantedEarlier {
        /// The entry.
        path: String,
        /// What it is.
        what: &'static str,
    },
    /// The output folder is a file.
    #[error("--out `{0}` is a file; give a folder (it is created if needed)")]
    NotAFolder(String),
    /// Something that is not a regular file stands where the command writes one (`R.npy` a
    /// folder): refused before any work, not after it.
    #[error(
        "`{path}` is {what}, where `{command}` writes a file: remove or rename it, or choose another --out"
    )]
    Blocked {
        /// The entry.
        path: String,
        /// What it is ("a folder", "a symlink", ...).
        what: &'static str,
        /// The command asked to write there.
        command: &'static str,
    },
    /// The output folder holds files of an earlier run of the same command.
    #[error(
        "--out `{dir}` already holds {count} file(s) of an earlier `{command}` run ({examples}): choose a new folder, or pass --force to delete those files first"
    )]
    FolderInUse {
        /// The folder.
        dir: String,
        /// The command asked to write there.
        command: &'static str,
        /// How many of its files the folder holds.
        count: usize,
        /// A few of their names.
        examples: String,
    },
    /// The output folder holds another command's run.
    #[error(
        "--out `{dir}` holds a `{other}` run ({manifest}); `{command}` writes into a folder of its own: choose another folder"
    )]
    OtherRun {
        /// The folder.
        dir: String,
        /// The other run's manifest.
        manifest: &'static str,
        /// The command that wrote it.
        other: &'static str,
        /// The command asked to write there.
        command: &'static str,
    },
    /// Another run is writing into the output folder.
    #[error(
        "--out `{dir}` is in use by another run that is still writing there: wait for it to end, or choose another folder for this `{command}` run"
    )]
    Busy {
        /// The folder.
        dir: String,
        /// The command asked to write there.
        command: &'static str,
    },
    /// The locked output folder was deleted or replaced while the run was writing there.
    #[error(
        "--out `{dir}` was deleted or replaced by another folder while this run was writing there; nothing more is written (the new folder may belong to another run): run again"
    )]
    FolderReplaced {
        /// The folder.
        dir: String,
    },
    /// An input of the run lies in the output folder under a name the command writes.
    #[error(
        "`{input}` is an input of this run, and `{command}` writes a file of that name into --out `{dir}` (--force would delete it, the run overwrite it): choose another --out, or move the input"
    )]
    InputIsOutput {
        /// The input file.
        input: String,
        /// The command.
        command: &'static str,
        /// The output folder.
        dir: String,
    },
    /// What a picture shows could not be computed (a spectrum of too short a record).
    #[error("cannot draw `{path}`: {source}")]
    Figure {
        /// The picture.
        path: String,
        /// Why.
        source: pendulum_atlas_core::analysis::AnalysisError,
    },
    /// A picture could not be drawn.
    #[cfg(feature = "pictures")]
    #[error("cannot draw `{path}`: {source}")]
    Render {
        /// The picture.
        path: String,
        /// The renderer's reason.
        source: crate::render::RenderError,
    },
}

impl OutputError {
    /// An I/O error on `path`.
    pub fn io(path: &std::path::Path, source: std::io::Error) -> OutputError {
        OutputError::Io {
            path: path.display().to_string(),
            source,
        }
    }
}
