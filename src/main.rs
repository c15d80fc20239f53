//! The `pendulum-atlas` binary: parse arguments, run the command, turn errors into exit codes.

mod cli;

use clap::Parser;

fn main() {
    quiet_headless_vulkan();
    let args = cli::Cli::parse();
    let ran = cli::run(args);
    match &ran {
        Err(e) if e.downcast_ref::<cli::RunFailed>().is_none() => cli::abandon_out(),
        _ => cli::keep_out(),
    }
    if let Err(e) = ran {
        eprintln!(
            "error: {}",
            pendulum_atlas_core::text::printable(&message(&e))
        );
        let failed_run = e.downcast_ref::<cli::RunFailed>().is_some();
        std::process::exit(match (failed_run, cli::interrupted()) {
            (_, true) => 130,
            (true, false) => 3,
            (false, false) => 2,
        });
    }
}

/// The error and its causes, each once: a cause whose text the message already holds (an error
/// that prints its source, as most of ours do) is not repeated.
fn message(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let part = cause.to_string();
        if text.contains(&part) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&part);
    }
    text
}

/// On a headless machine (no XDG_RUNTIME_DIR), Mesa's Vulkan drivers print
/// "error: XDG_RUNTIME_DIR is invalid or not set" when wgpu opens them, although compute works
/// fine. Point the variable at a private temporary directory so that researchers do not see a
/// false error on every GPU run. Done first thing in `main`, before any thread exists.
fn quiet_headless_vulkan() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
        return;
    }
    let user = std::env::var("USER").unwrap_or_else(|_| "user".into());
    let dir = std::env::temp_dir().join(format!("pendulum-atlas-runtime-{user}"));
    if std::fs::create_dir_all(&dir).is_err() {
        return;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let _ = std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700));
    }
    // SAFETY: called at the start of `main`, before any other thread is spawned, so no other
    // thread can be reading the environment concurrently.
    unsafe { std::env::set_var("XDG_RUNTIME_DIR", &dir) };
}
