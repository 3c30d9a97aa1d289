//! The `rsl` command-line tool: parses arguments and calls the library.

use clap::Parser;

fn main() -> std::process::ExitCode {
    runtime_dir();
    let cli = rsl::cli::Cli::parse();
    logging(cli.quiet);
    match rsl::cli::run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// rsl's own crates, whose warnings (a clamped map, a rejected cache file, a cache that
/// cannot be written) are shown by default.
const OWN: [&str; 12] = [
    "rsl",
    "rsl_engine",
    "rsl_env",
    "rsl_scene",
    "rsl_bench",
    "rsl_gpu",
    "rsl_vis",
    "rsl_truth",
    "rsl_lobe",
    "rsl_shade",
    "rsl_brdf",
    "rsl_sphere",
];

/// Diagnostics on stderr: with RUST_LOG set, what it asks for, in full; otherwise rsl's own
/// warnings and everyone's errors (`--quiet`: errors only), each once, as `warning: …`
/// lines, coloured only on a terminal.
fn logging(quiet: bool) {
    use std::io::IsTerminal;
    let ansi = std::io::stderr().is_terminal();
    if std::env::var_os("RUST_LOG").is_some_and(|v| !v.is_empty()) {
        tracing_subscriber::fmt()
            .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
            .with_writer(std::io::stderr)
            .with_ansi(ansi)
            .init();
        return;
    }
    let level = if quiet { "error" } else { "warn" };
    let directives: Vec<String> =
        std::iter::once("error".to_string()).chain(OWN.iter().map(|c| format!("{c}={level}"))).collect();
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::new(directives.join(",")))
        .with_writer(std::io::stderr)
        .with_ansi(ansi)
        .without_time()
        .with_target(false)
        .with_level(true)
        .compact()
        .init();
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
