//! The `waggle` command line: one small adapter per command, each parsing its arguments
//! (clap), calling the library and printing the result. `src/main.rs` only dispatches; the lab
//! commands go to the `waggle-lab` binary ([`lab`]), whose adapters are the `lab` crate's.

pub mod allocate;
pub mod audit;
pub mod bench;
pub mod bundle;
pub mod compose;
pub mod export;
pub mod lab;
pub mod payload;
pub mod replay;
pub mod router;
pub mod run;
pub mod up;

/// `--flights sequential|concurrent`, shared by the commands that fly a whole case.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct FlightsArg {
    /// Safety router, overriding the case's `flights`: `sequential` flies one trip at a time
    /// (the paper), `concurrent` lets trips overlap when their reserved space-time paths keep
    /// the 0.4 m clearance.
    #[arg(long = "flights", value_enum)]
    pub mode: Option<proto::FlightMode>,
}

impl FlightsArg {
    /// `case` with the override applied.
    pub fn apply(self, mut case: crate::case::Case) -> crate::case::Case {
        if let Some(mode) = self.mode {
            case.flights = mode;
        }
        case
    }
}

/// `--sensor-preset NAME` and `--perturb KEY=VALUE…`, shared by the commands that perturb.
#[derive(Debug, Clone, clap::Args)]
pub struct PerturbArgs {
    /// A named sensor preset (`v2e-clean`, `v2e-default`, `v2e-noisy`, `dvs-dim`): its `events.*` terms,
    /// under any --perturb given too. None: the paper's ideal sensors.
    #[arg(long = "sensor-preset", value_name = "NAME")]
    pub sensor_preset: Option<String>,
    /// A perturbation term KEY=VALUE (repeatable; `waggle trials --help` lists them).
    #[arg(long = "perturb", value_name = "KEY=VALUE")]
    pub perturb: Vec<String>,
}

impl PerturbArgs {
    /// The preset's terms, then every --perturb over them.
    pub fn perturbation(&self) -> anyhow::Result<perturb::Perturbation> {
        Ok(perturb::Perturbation::with_preset(
            self.sensor_preset.as_deref(),
            &self.perturb,
        )?)
    }
}

/// `--render raster|damage|full`, shared by every command that renders cameras.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct RenderArg {
    /// How cameras render: `raster` (the default) is Waggle's CPU renderer (no GL; only the
    /// moved bodies' rectangle, each body at a level of detail for its size); `damage` (alias
    /// `mujoco`) is MuJoCo's renderer, the paper's, redrawing only what moved since a camera's
    /// last frame, `full` MuJoCo's renderer redrawing every pixel (byte-identical to `damage`).
    #[arg(long = "render", value_enum, default_value_t)]
    pub path: proto::RenderPath,
}
