//! Per-trial records: every finished trial is written at once to its own file,
//! `<point>/trials/NNNNNN.json`, through a temporary file and a rename (atomic on POSIX), with a
//! SHA-256 of its content. A run that is killed loses at most the trials still running; a rerun
//! reads what is recorded, sets damaged files aside (`*.damaged`) and runs only what is missing.
//! `trials.json`, `study.json` and the report are always regenerated from these records (in one
//! process or merged from shards), so they are byte-identical however the trials were split.
//!
//! Each record also names the binary that made it, the host's CPU model and its renderer
//! ([`Provenance`]): shards made by different binaries are not merged.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use anyhow::{Context, Result, bail};
use serde::Serialize;
use sha2::{Digest, Sha256};

use proto::RenderPath;

use crate::harness::trials::out::TrialRecord;

/// The records' directory inside a point's directory.
pub const RECORDS_DIR: &str = "trials";
/// A point's header (what its `trials.json` holds besides the records), written once flown.
pub const HEADER_FILE: &str = "point.json";
/// What a run directory is a run of (`waggle study` or `waggle trials`, shard, definition).
pub const MANIFEST_FILE: &str = "run.json";
pub use run_format::trial_record::{Provenance, Recordable};

/// This process's provenance for cameras rendered by `render` (the binary's digest is computed
/// once: hashing the executable takes ≈ 0.1 s).
pub fn provenance_here(render: RenderPath) -> Result<Provenance> {
    static HERE: OnceLock<std::result::Result<(String, String), String>> = OnceLock::new();
    let (version, cpu) = HERE
        .get_or_init(|| Ok((binary_version().map_err(|e| format!("{e:#}"))?, cpu_model())))
        .as_ref()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok(Provenance {
        version: version.clone(),
        cpu: cpu.clone(),
        renderer: renderer(render),
    })
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn binary_version() -> Result<String> {
    let exe = std::env::current_exe().context("finding this executable")?;
    let mut file =
        std::fs::File::open(&exe).with_context(|| format!("reading {}", exe.display()))?;
    let mut hasher = Sha256::new();
    std::io::copy(&mut file, &mut hasher).with_context(|| format!("hashing {}", exe.display()))?;
    let digest = hex(&hasher.finalize());
    Ok(format!(
        "{} sha256:{}",
        env!("CARGO_PKG_VERSION"),
        &digest[..16]
    ))
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, m)| m.trim().to_owned())
        })
        .unwrap_or_else(|| "unknown".into())
}

/// The renderer `render` names: Waggle's by its identifier; MuJoCo's by Mesa's EGL package
/// version (Debian) and the driver overrides that change which rasteriser draws. The lab holds no
/// GL context of its own (no `unsafe`), so this names the stack rather than asking it.
fn renderer(render: RenderPath) -> String {
    if !render.is_mujoco() {
        return sim::render::RASTER_RENDERER_ID.to_owned();
    }
    static MESA: OnceLock<String> = OnceLock::new();
    let stack = MESA.get_or_init(|| {
        // A relocatable bundle carries its own Mesa and says which (deploy/relocatable.sh).
        let bundled = std::env::var("WAGGLE_MESA_VERSION")
            .ok()
            .filter(|v| !v.is_empty());
        let mesa = bundled.unwrap_or_else(|| {
            crate::host_command("dpkg-query")
                .args(["-W", "-f=${Version}", "libegl-mesa0"])
                .output()
                .ok()
                .filter(|o| o.status.success())
                .map_or_else(
                    || "unknown".to_owned(),
                    |o| String::from_utf8_lossy(&o.stdout).trim().to_owned(),
                )
        });
        let mut s = format!("EGL, Mesa {mesa}");
        for var in ["GALLIUM_DRIVER", "LIBGL_ALWAYS_SOFTWARE", "EGL_PLATFORM"] {
            if let Ok(v) = std::env::var(var) {
                s.push_str(&format!(", {var}={v}"));
            }
        }
        s
    });
    format!("MuJoCo {render}, {stack}")
}

/// `dir/trials/NNNNNN.json`.
pub fn record_path(point_dir: &Path, index: u64) -> PathBuf {
    point_dir.join(RECORDS_DIR).join(format!("{index:06}.json"))
}

/// Writes `bytes` to `path` atomically: a temporary file beside it, flushed to disk, renamed.
/// Concurrent writers of the same content each rename their own file, so a reader sees one
/// whole file or none.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let tmp = dir.join(format!(
        ".{}.tmp-{}-{:?}",
        path.file_name()
            .map_or("file".into(), |n| n.to_string_lossy()),
        std::process::id(),
        std::thread::current().id()
    ));
    let mut file =
        std::fs::File::create(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
    file.write_all(bytes)
        .and_then(|()| file.sync_all())
        .with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path)
        .with_context(|| format!("renaming {} to {}", tmp.display(), path.display()))
}

/// `value` as pretty JSON with a final newline, written atomically.
pub fn write_json(path: &Path, value: &impl Serialize) -> Result<()> {
    write_atomic(
        path,
        (serde_json::to_string_pretty(value)? + "\n").as_bytes(),
    )
}

/// Reads a JSON file written by [`write_json`].
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_slice(&bytes)
        .with_context(|| format!("{}: not the expected JSON", path.display()))
}

/// Records trial `record` of point `point` (its directory name) in `point_dir`, its cameras
/// rendered by `render`.
pub fn write_record<R: Recordable>(
    point_dir: &Path,
    point: &str,
    render: RenderPath,
    record: &R,
) -> Result<()> {
    let bytes = run_format::trial_record::encode(point, provenance_here(render)?, record)?;
    write_atomic(&record_path(point_dir, record.record_index()), &bytes)
}

/// A point's recorded trials, read and checked.
#[derive(Debug)]
pub struct RecordScan<R = TrialRecord> {
    /// Good records by index.
    pub records: BTreeMap<u64, (R, Provenance)>,
    /// Files that are not a good record of this point: path and why.
    pub damaged: Vec<(PathBuf, String)>,
}

impl<R> Default for RecordScan<R> {
    fn default() -> Self {
        Self {
            records: BTreeMap::new(),
            damaged: Vec::new(),
        }
    }
}

/// Why the record at `path` is not trial `index` of `point`, or the record.
fn read_record<R: Recordable>(
    path: &Path,
    point: &str,
    index: u64,
) -> Result<(R, Provenance), String> {
    let bytes = std::fs::read(path).map_err(|e| format!("unreadable: {e}"))?;
    run_format::trial_record::parse(&bytes, point, index).map_err(|e| e.to_string())
}

/// Reads every record of `point` in `point_dir` (trials `0..requested`); anything else in the
/// records directory that looks like a record is reported damaged.
pub fn scan<R: Recordable>(point_dir: &Path, point: &str, requested: u64) -> Result<RecordScan<R>> {
    let mut scan = RecordScan::default();
    let dir = point_dir.join(RECORDS_DIR);
    let entries = match std::fs::read_dir(&dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(scan),
        Err(e) => return Err(e).with_context(|| format!("listing {}", dir.display())),
    };
    for entry in entries {
        let path = entry
            .with_context(|| format!("listing {}", dir.display()))?
            .path();
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
        let Some(stem) = name.as_deref().and_then(|n| n.strip_suffix(".json")) else {
            continue; // temporary files and records already set aside
        };
        match stem.parse::<u64>() {
            Ok(index) if index < requested => match read_record(&path, point, index) {
                Ok(r) => {
                    scan.records.insert(index, r);
                }
                Err(why) => scan.damaged.push((path, why)),
            },
            _ => scan
                .damaged
                .push((path, format!("not a trial of 0..{requested}"))),
        }
    }
    scan.damaged.sort();
    Ok(scan)
}

/// Reads a point's recorded trials, setting damaged ones aside (they are rerun), and refuses
/// records made by another binary or with another renderer than `render`'s.
pub fn recorded<R: Recordable>(
    dir: &Path,
    point: &str,
    requested: u64,
    render: RenderPath,
) -> Result<(RecordScan<R>, u64)> {
    let mut found = scan::<R>(dir, point, requested)?;
    for (path, why) in &found.damaged {
        eprintln!("damaged record {}: {why}; running it again", path.display());
        set_aside(path)?;
    }
    let here = provenance_here(render)?;
    if let Some((i, (_, p))) = found
        .records
        .iter()
        .find(|(_, (_, p))| p.version != here.version)
    {
        bail!(
            "{}: trial {i} was recorded by waggle {}, this is {}: results of different \
             binaries are not mixed; rerun with that binary or into another --out",
            dir.display(),
            p.version,
            here.version
        );
    }
    if let Some((i, (_, p))) = found
        .records
        .iter()
        .find(|(_, (_, p))| p.renderer != here.renderer)
    {
        bail!(
            "{}: trial {i} was rendered by {}, this run renders by {}: results of different \
             renderers are not mixed; rerun with that --render or into another --out",
            dir.display(),
            p.renderer,
            here.renderer
        );
    }
    let damaged = found.damaged.len() as u64;
    found.damaged.clear();
    Ok((found, damaged))
}

/// Moves a damaged record out of the way (`NNNNNN.json.damaged`), keeping it for inspection.
pub fn set_aside(path: &Path) -> Result<()> {
    let mut aside = path.as_os_str().to_owned();
    aside.push(".damaged");
    std::fs::rename(path, &aside).with_context(|| format!("moving {} aside", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(index: u64) -> TrialRecord {
        TrialRecord {
            index,
            seed: 0x1234_5678_9abc_def0 ^ index,
            success: index.is_multiple_of(2),
            observers: BTreeMap::new(),
            flight: None,
            plugin_failure: None,
        }
    }

    #[test]
    fn records_round_trip_and_damage_is_detected() {
        let dir = std::env::temp_dir().join(format!("waggle-records-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for i in 0..4 {
            write_record(&dir, "rgb-0", RenderPath::default(), &record(i)).unwrap();
        }
        let s = scan::<TrialRecord>(&dir, "rgb-0", 4).unwrap();
        assert_eq!(s.records.len(), 4);
        assert!(s.damaged.is_empty());
        assert_eq!(s.records[&3].0, record(3));
        // A flipped digit (valid JSON, wrong checksum), a truncated file, a record of another
        // point under this name, and a stray index are all reported; the rest stay good.
        let p1 = record_path(&dir, 1);
        let text = std::fs::read_to_string(&p1).unwrap();
        std::fs::write(
            &p1,
            text.replacen("\"success\":false", "\"success\":true", 1),
        )
        .unwrap();
        let p2 = record_path(&dir, 2);
        std::fs::write(&p2, &std::fs::read(&p2).unwrap()[..40]).unwrap();
        write_record(&dir, "rgb-9", RenderPath::default(), &record(0)).unwrap();
        let s = scan::<TrialRecord>(&dir, "rgb-0", 3).unwrap();
        let why: Vec<&str> = s.damaged.iter().map(|(_, w)| w.as_str()).collect();
        assert_eq!(
            s.records.keys().copied().collect::<Vec<_>>(),
            Vec::<u64>::new(),
            "{why:?}"
        );
        assert_eq!(s.damaged.len(), 4, "{why:?}");
        assert!(why.iter().any(|w| w.contains("checksum")), "{why:?}");
        assert!(
            why.iter().any(|w| w.contains("not a trial record")),
            "{why:?}"
        );
        assert!(why.iter().any(|w| w.contains("rgb-9")), "{why:?}");
        assert!(why.iter().any(|w| w.contains("0..3")), "{why:?}");
        for (p, _) in &s.damaged {
            set_aside(p).unwrap();
        }
        assert!(
            scan::<TrialRecord>(&dir, "rgb-0", 4)
                .unwrap()
                .damaged
                .is_empty()
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
