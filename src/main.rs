//! The `rsl` command-line tool: parses arguments and calls the library.

use clap::Parser;

fn main() -> std::process::ExitCode {
    runtime_dir();
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .with_writer(std::io::stderr)
        .init();
    match rsl::cli::run(rsl::cli::Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// Gives the process a private runtime folder when `XDG_RUNTIME_DIR` is unset or not a
/// folder. Opening a GPU adapter loads the Vulkan driver, whose window-system support looks
/// for that folder and otherwise prints "error: XDG_RUNTIME_DIR is invalid…" — on runs that
/// never open a window and work fine. Nothing of rsl's is written there.
fn runtime_dir() {
    const VAR: &str = "XDG_RUNTIME_DIR";
    if std::env::var_os(VAR).is_some_and(|d| std::path::Path::new(&d).is_dir()) {
        return;
    }
    let user = std::env::var("USER").unwrap_or_else(|_| "user".into());
    let dir = std::env::temp_dir().join(format!("rsl-runtime-{user}"));
    let mut builder = std::fs::DirBuilder::new();
    #[cfg(unix)]
    std::os::unix::fs::DirBuilderExt::mode(&mut builder, 0o700);
    if builder.create(&dir).is_err() && !dir.is_dir() {
        return;
    }
    // SAFETY: this runs first in `main`, before any other thread exists, so nothing reads
    // the environment while it changes.
    #[allow(unsafe_code)]
    unsafe {
        std::env::set_var(VAR, &dir);
    }
}
