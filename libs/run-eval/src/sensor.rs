//! The event cameras' sensor model of a session run as processes (`waggle run`/`compose`
//! `--sensor-preset NAME --perturb events.KEY=VALUE --seed S`): [`node_args::SensorArgs`],
//! handed to every camera process as part of its own arguments, which builds observer i's
//! sensor with `stream_seed(seed, Stream::EventSensor, i)` — the sensors `waggle mission` builds.
//! No preset and no term: no argument at all, so such a session's nodes and outputs are the
//! ones it always had.

use anyhow::Result;
use node_args::SensorArgs;

use run_format::run_dir::SensorRecord;

/// What the run directory records of a sensor model (`None`: ideal sensors, nothing recorded).
pub fn record(sensor: &SensorArgs) -> Result<Option<SensorRecord>> {
    if sensor.is_none() {
        return Ok(None);
    }
    Ok(Some(SensorRecord {
        preset: sensor.preset.clone(),
        terms: sensor.perturb.clone(),
        perturb: sensor.perturbation()?.recorded(),
        seed: sensor.seed,
    }))
}
