//! The binaries' `tracing` setup.

/// Logs to stderr, coloured only on a terminal, filtered by `RUST_LOG`
/// or else by `default` (an `EnvFilter` directive such as `"info"`).
pub fn init(default: &str) {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default)),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
}
