//! A real recording read as a real-noise source ([`event_camera::real_noise`]): found by path
//! or by `PACKAGE/FILE` among the recordings setup fetches, named by its SHA-256, its
//! background told from its signal as `waggle sensor-fit` tells it.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use anyhow::{Context, Result, bail};
use commands::decode::EventFormat;
use event_camera::fit::Background;
use event_camera::real_noise::RealNoise;
use sha2::{Digest, Sha256};

use crate::harness::decode::source::read_events;

/// `spec` as a file: a path that exists, else `third_party/PACKAGE/data/FILE` for
/// `PACKAGE/FILE`.
pub fn resolve(spec: &str) -> Result<PathBuf> {
    let given = Path::new(spec);
    if given.exists() {
        return Ok(given.to_path_buf());
    }
    if let Some((package, file)) = spec.split_once('/') {
        let fetched = sim::assets::third_party_dir()
            .join(package)
            .join("data")
            .join(file);
        if fetched.exists() {
            return Ok(fetched);
        }
        bail!(
            "real-noise source {spec:?}: neither a file nor a fetched recording ({} is missing; \
             `bash deploy/setup.sh` fetches them)",
            fetched.display()
        );
    }
    bail!("real-noise source {spec:?}: no such file")
}

/// Sources read by this process, by file and window: a study's points share one.
type Loaded = Vec<((PathBuf, Option<(u64, u64)>), Arc<RealNoise>)>;
static LOADED: Mutex<Loaded> = Mutex::new(Vec::new());

/// The background of the recording `spec` names: the stretch `static_s` (seconds from its
/// first event) or its isolated events.
pub fn load(spec: &str, static_s: Option<(f64, f64)>) -> Result<Arc<RealNoise>> {
    let path = resolve(spec)?;
    let key = (
        path.clone(),
        static_s.map(|(a, b)| (a.to_bits(), b.to_bits())),
    );
    let mut loaded = LOADED
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some((_, source)) = loaded.iter().find(|(k, _)| *k == key) {
        return Ok(source.clone());
    }
    let source = read_source(spec, &path, static_s)?;
    loaded.push((key, source.clone()));
    Ok(source)
}

fn read_source(spec: &str, path: &Path, static_s: Option<(f64, f64)>) -> Result<Arc<RealNoise>> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let digest: String = Sha256::digest(&bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    drop(bytes);
    let read = read_events(path, EventFormat::Auto, None)?;
    let Some(first) = read.events.first().map(|e| e.t_ns) else {
        bail!("real-noise source {spec}: the recording holds no events");
    };
    let (width, height) = read.sensor_size();
    let background = Background::from_window(first, static_s);
    let name = path
        .file_name()
        .map_or_else(|| spec.to_owned(), |n| n.to_string_lossy().into_owned());
    let source = RealNoise::from_recording(&name, &digest, &read.events, width, height, background)
        .with_context(|| format!("real-noise source {spec}"))?;
    if source.is_empty() {
        bail!("real-noise source {spec}: its background holds no events");
    }
    Ok(Arc::new(source))
}
