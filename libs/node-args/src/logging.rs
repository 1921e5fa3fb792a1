//! The node processes' logging, set up one way: `tracing` events to standard error (the
//! launcher keeps each node's stderr in `DIR/logs/`), filtered by `RUST_LOG`.

/// Installs the node's log subscriber; call once, first thing in `main`.
pub fn init_logging() {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .with_writer(std::io::stderr)
        .init();
}
