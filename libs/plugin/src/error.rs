//! What can go wrong with a plug-in, each naming the plug-in's part or the observer it served.

/// A plug-in that could not be named, started or used.
#[derive(Debug, thiserror::Error)]
pub enum PluginError {
    #[error("receiver plug-in {spec:?}: {why}")]
    Spec { spec: String, why: String },
    #[error("could not start the plug-in worker `{python} -m waggle._worker` for {spec}: {source}")]
    Spawn {
        python: String,
        spec: String,
        source: std::io::Error,
    },
    /// The plug-in raised (or could not be imported or built); `message` is its exception.
    #[error("{spec} raised in {call} ({observer}): {message}")]
    Raised {
        spec: String,
        observer: String,
        call: String,
        message: String,
    },
    /// The plug-in returned something that is not what its level promises.
    #[error("{spec} returned malformed output from {call} ({observer}): {why}")]
    Malformed {
        spec: String,
        observer: String,
        call: String,
        why: String,
    },
    #[error("{spec} ran past its time limit of {limit_s} s (in {call}, {observer})")]
    TimedOut {
        spec: String,
        observer: String,
        call: String,
        limit_s: f64,
    },
    #[error("the worker of {spec} ended ({status}) during {call} ({observer})")]
    WorkerGone {
        spec: String,
        observer: String,
        call: String,
        status: String,
    },
    #[error("writing to the worker of {spec}: {source}")]
    Pipe {
        spec: String,
        source: std::io::Error,
    },
}

impl PluginError {
    /// How a trial that met this error ends: `timed-out` (a wall clock decided it) or `failed`.
    pub fn outcome(&self) -> &'static str {
        match self {
            Self::TimedOut { .. } => "timed-out",
            _ => "failed",
        }
    }

    /// Whether the plug-in itself is to blame (it raised, returned nonsense, hung or died), as
    /// opposed to an unusable spec or interpreter, which fails the run instead of one trial.
    pub fn is_plugin_fault(&self) -> bool {
        !matches!(self, Self::Spec { .. } | Self::Spawn { .. })
    }
}
