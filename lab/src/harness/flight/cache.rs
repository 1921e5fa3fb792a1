//! A render cache on disk, shared by every process on one host (`--render-cache DIR`): the
//! shards of a study that a cluster places on the same node fly and render each shared flight
//! once between them, and a resumed run does not fly again what it flew before it was cut.
//!
//! An entry is addressed by the SHA-256 of everything that decides its content: the flight's
//! full specification, the binary (its version and executable hash), the CPU model and the
//! renderer ([`Provenance`]: llvmpipe's output may depend on the CPU's instruction set). Another
//! binary or machine kind simply misses, so a cache directory shared over a network file system
//! never hands one host's renders to another kind of host.
//!
//! Concurrent writers are safe: a process takes an exclusive lock on the entry's lock file
//! (`flock`) before it looks, so a second shard asking for a flight the first is rendering waits
//! for it and then reads it, rather than rendering it again. An entry is written to a temporary
//! file, synced and renamed into place, so a killed writer leaves no partial entry (its
//! temporary file is removed by the next writer of that entry, which holds the lock). Every
//! entry ends with the SHA-256 of its bytes; a damaged entry is counted, set aside
//! (`*.damaged`) and flown again: the cache can cost time, never change a result.
//!
//! Entries are never evicted: remove the directory when a study is done (a node-local
//! scratch directory suits it).

use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, ensure};
use proto::Modality;
use run_format::render_cache::{self, EntryFor, FORMAT, Meta, TrackMeta};
use sha2::{Digest, Sha256};

use crate::harness::flight::rendered::{
    FlightSpec, RenderTrack, RenderedFlight, Update, fly_rendered,
};
use crate::harness::link::ObserverOut;
use crate::harness::runs::records::provenance_here;

/// The ideal receivers' output a cache entry holds.
type Ideal = BTreeMap<Modality, Vec<ObserverOut>>;

/// A render cache directory.
#[derive(Debug, Clone)]
pub struct RenderCache {
    dir: PathBuf,
}

/// How a flight was obtained.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Fetched {
    /// Read from the cache.
    Hit,
    /// Flown and rendered now (and stored).
    Flown,
    /// The entry was damaged (why), set aside, and the flight flown again.
    Replaced(String),
}

fn track_meta(t: &RenderTrack) -> TrackMeta {
    TrackMeta {
        frame_len: t.frame_len,
        width: t.width,
        updates: t
            .updates
            .iter()
            .map(|u| (u.stamp_ns, u.change, u.pixels.len()))
            .collect(),
    }
}

impl RenderCache {
    /// The cache in `dir` (created if absent).
    ///
    /// # Errors
    ///
    /// When the directory cannot be created.
    pub fn open(dir: &Path) -> Result<Self> {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("creating the render cache {}", dir.display()))?;
        Ok(Self {
            dir: dir.to_path_buf(),
        })
    }

    /// The cache's directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The address of `spec`'s entry: hex SHA-256 of the format, this binary and host kind, and
    /// the specification.
    ///
    /// # Errors
    ///
    /// When this binary's provenance cannot be computed.
    pub fn key(spec: &FlightSpec) -> Result<String> {
        let p = provenance_here(spec.render)?;
        let mut h = Sha256::new();
        for part in [
            FORMAT,
            &p.version,
            &p.cpu,
            &p.renderer,
            &format!("{spec:?}"),
        ] {
            h.update((part.len() as u64).to_le_bytes());
            h.update(part.as_bytes());
        }
        Ok(hex(&h.finalize()))
    }

    fn entry(&self, key: &str) -> PathBuf {
        self.dir.join(format!("{key}.renders"))
    }

    /// `spec`'s flight: read from the cache, or flown, rendered and stored. Holds the entry's
    /// lock throughout, so a concurrent request for the same flight waits and then reads it.
    ///
    /// # Errors
    ///
    /// When the flight fails, or the cache cannot be locked or written.
    pub fn fly(&self, spec: FlightSpec) -> Result<(RenderedFlight, Fetched)> {
        let key = Self::key(&spec)?;
        let lock_path = self.dir.join(format!("{key}.lock"));
        let lock = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&lock_path)
            .with_context(|| format!("opening {}", lock_path.display()))?;
        lock.lock()
            .with_context(|| format!("locking {}", lock_path.display()))?;
        let path = self.entry(&key);
        let mut fetched = Fetched::Flown;
        if path.exists() {
            match read_entry(&path, &key, &spec) {
                Ok(flight) => return Ok((flight, Fetched::Hit)),
                Err(why) => {
                    let why = format!("{why:#}");
                    let aside = path.with_extension("renders.damaged");
                    std::fs::rename(&path, &aside)
                        .with_context(|| format!("setting the damaged {} aside", path.display()))?;
                    fetched = Fetched::Replaced(why);
                }
            }
        }
        self.remove_temporaries(&key)?;
        let flight = fly_rendered(spec)?;
        // Shared flights keep their cameras still; one that turns an airframe is flown per
        // trial and never reaches the cache, whose entries hold no attitude.
        ensure!(
            !flight.tracks.iter().any(RenderTrack::turned),
            "this flight turns an observer's airframe: the render cache keeps still cameras only"
        );
        let bytes = encode(&flight, &key)?;
        let tmp = self.dir.join(format!("{key}.tmp-{}", std::process::id()));
        write_synced(&tmp, &bytes)?;
        std::fs::rename(&tmp, &path)
            .with_context(|| format!("renaming {} into place", tmp.display()))?;
        if let Ok(d) = File::open(&self.dir) {
            // The rename is durable once the directory is synced; a failure only risks a miss.
            let _ = d.sync_all();
        }
        drop(lock);
        Ok((flight, fetched))
    }

    /// Removes what killed writers of `key` left (only the lock's holder writes an entry).
    fn remove_temporaries(&self, key: &str) -> Result<()> {
        let prefix = format!("{key}.tmp-");
        let entries = std::fs::read_dir(&self.dir)
            .with_context(|| format!("listing {}", self.dir.display()))?;
        for e in entries.flatten() {
            if e.file_name().to_string_lossy().starts_with(&prefix) {
                std::fs::remove_file(e.path())
                    .with_context(|| format!("removing {}", e.path().display()))?;
            }
        }
        Ok(())
    }
}

/// Flies `spec` through `cache` when there is one (see [`RenderCache::fly`]); reports a damaged
/// entry on stderr.
///
/// # Errors
///
/// As [`RenderCache::fly`] and [`fly_rendered`].
pub fn fly_through(
    cache: Option<&RenderCache>,
    spec: FlightSpec,
) -> Result<(RenderedFlight, Fetched)> {
    match cache {
        None => Ok((fly_rendered(spec)?, Fetched::Flown)),
        Some(c) => {
            let (flight, fetched) = c.fly(spec)?;
            if let Fetched::Replaced(why) = &fetched {
                eprintln!(
                    "render cache {}: a damaged entry ({why}) was set aside and flown again",
                    c.dir().display()
                );
            }
            Ok((flight, fetched))
        }
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn write_synced(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut f = File::create(path).with_context(|| format!("creating {}", path.display()))?;
    f.write_all(bytes)
        .and_then(|()| f.sync_all())
        .with_context(|| format!("writing {}", path.display()))
}

/// An entry's bytes ([`render_cache::encode`]).
fn encode(flight: &RenderedFlight, key: &str) -> Result<Vec<u8>> {
    let meta = Meta {
        format: FORMAT.into(),
        key: key.into(),
        spec: format!("{:?}", flight.spec),
        provenance: provenance_here(flight.spec.render)?,
        ideal: &flight.ideal,
        sim_ns: flight.sim_ns,
        performer_max_tracking_error_m: flight.performer_max_tracking_error_m,
        contact_steps: flight.contact_steps,
        tracks: flight.tracks.iter().map(track_meta).collect(),
    };
    let pixels = flight
        .tracks
        .iter()
        .flat_map(|t| &t.updates)
        .map(|u| u.pixels.as_slice());
    Ok(render_cache::encode(&meta, pixels)?)
}

/// Reads and checks the entry at `path` for `key`; the flight's `spec` is the caller's (the key
/// covers it).
fn read_entry(path: &Path, key: &str, spec: &FlightSpec) -> Result<RenderedFlight> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    decode(&bytes, key, spec)
}

fn decode(bytes: &[u8], key: &str, spec: &FlightSpec) -> Result<RenderedFlight> {
    let expected = EntryFor {
        key,
        observers: spec.formation.len(),
    };
    let entry = render_cache::decode::<Ideal>(bytes, Some(expected))?;
    let meta = entry.meta;
    let tracks = meta
        .tracks
        .into_iter()
        .zip(entry.pixels)
        .map(|(t, pixels)| RenderTrack {
            frame_len: t.frame_len,
            width: t.width,
            updates: t
                .updates
                .into_iter()
                .zip(pixels)
                .map(|((stamp_ns, change, _), pixels)| Update {
                    stamp_ns,
                    change,
                    pixels,
                    ego: None,
                })
                .collect(),
        })
        .collect();
    Ok(RenderedFlight {
        spec: spec.clone(),
        tracks,
        ideal: meta.ideal,
        sim_ns: meta.sim_ns,
        performer_max_tracking_error_m: meta.performer_max_tracking_error_m,
        contact_steps: meta.contact_steps,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::trials::TrialsOptions;
    use perturb::Perturbation;
    use proto::scene::Formation;
    use proto::{Modality, Rectification, RenderPath};

    /// A short real flight (MuJoCo and the renderer): one observer, 1.5 s.
    fn spec(end_ns: u64) -> FlightSpec {
        let opts = TrialsOptions {
            payloads: vec![0b011010],
            formation: Formation::standard(1).unwrap(),
            modality: Modality::Rgb,
            trials: 1,
            seed: 0,
            perturbation: Perturbation::parse::<&str>(&[]).unwrap(),
            jobs: 1,
            render: RenderPath::Damage,
            rectification: Rectification::Pitched,
            acquisition: Some(false),
            plugin: None,
            frame_check: proto::FrameCheck::None,
        };
        let mut spec = opts.shared_flight_spec(40_000_000).unwrap();
        spec.end_ns = end_ns;
        spec
    }

    /// A flight rendered by one renderer is never served to a request for another.
    #[test]
    fn the_renderer_is_part_of_the_key() {
        let mut keys: Vec<String> = RenderPath::ALL
            .iter()
            .map(|&render| {
                let mut s = spec(1_500_000_000);
                s.render = render;
                RenderCache::key(&s).unwrap()
            })
            .collect();
        keys.sort();
        keys.dedup();
        assert_eq!(keys.len(), RenderPath::ALL.len());
    }

    fn same(a: &RenderedFlight, b: &RenderedFlight) {
        assert_eq!(a.tracks, b.tracks);
        assert_eq!(
            serde_json::to_string(&a.ideal).unwrap(),
            serde_json::to_string(&b.ideal).unwrap()
        );
        assert_eq!((a.sim_ns, a.contact_steps), (b.sim_ns, b.contact_steps));
        assert_eq!(
            a.performer_max_tracking_error_m.to_bits(),
            b.performer_max_tracking_error_m.to_bits()
        );
    }

    /// A directory of this test process, removed when dropped.
    struct Scratch(PathBuf);

    impl Scratch {
        fn new(name: &str) -> Self {
            let d = std::env::temp_dir()
                .join(format!("waggle-render-cache-{}-{name}", std::process::id()));
            let _ = std::fs::remove_dir_all(&d);
            Self(d)
        }

        fn path(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn entries(dir: &Path, ending: &str) -> usize {
        std::fs::read_dir(dir)
            .unwrap()
            .filter(|e| {
                e.as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .ends_with(ending)
            })
            .count()
    }

    /// Stored, read back equal; another flight is another entry; damage of any kind is found,
    /// set aside and flown again with the same result; a killed writer's leftover is removed.
    #[test]
    fn a_cached_flight_reads_back_exactly_and_damage_is_flown_again() {
        let dir = Scratch::new("read-back");
        let cache = RenderCache::open(dir.path()).unwrap();
        let s = spec(1_500_000_000);
        let key = RenderCache::key(&s).unwrap();
        std::fs::write(dir.path().join(format!("{key}.tmp-999999")), b"partial").unwrap();
        let (flown, how) = cache.fly(s.clone()).unwrap();
        assert_eq!(how, Fetched::Flown);
        assert!(flown.stored_bytes() > 0 && flown.sim_ns > 0);
        assert_eq!(entries(dir.path(), ".renders"), 1);
        assert!(!dir.path().join(format!("{key}.tmp-999999")).exists());
        let (read, how) = cache.fly(s.clone()).unwrap();
        assert_eq!(how, Fetched::Hit);
        same(&flown, &read);
        assert_eq!(read.spec.end_ns, s.end_ns);

        let other = spec(1_000_000_000);
        assert_ne!(RenderCache::key(&other).unwrap(), key);
        let (o, how) = cache.fly(other).unwrap();
        assert_eq!(how, Fetched::Flown);
        assert_ne!(o.tracks, flown.tracks);

        let path = cache.entry(&key);
        let good = std::fs::read(&path).unwrap();
        let flip_pixel = good.len() - render_cache::DIGEST_LEN - 5;
        type Damage = Box<dyn Fn(&mut Vec<u8>)>;
        let damages: [(&str, Damage); 4] = [
            ("a pixel", Box::new(move |b| b[flip_pixel] ^= 0x10)),
            ("the digest", Box::new(|b| *b.last_mut().unwrap() ^= 1)),
            ("cut short", Box::new(|b| b.truncate(b.len() / 2))),
            ("empty", Box::new(|b| b.clear())),
        ];
        for (k, (what, damage)) in damages.iter().enumerate() {
            let mut bytes = good.clone();
            damage(&mut bytes);
            std::fs::write(&path, &bytes).unwrap();
            let (again, how) = cache.fly(s.clone()).unwrap();
            assert!(matches!(how, Fetched::Replaced(_)), "{what}: {how:?}");
            same(&flown, &again);
            assert_eq!(std::fs::read(&path).unwrap(), good, "{what}");
            assert!(
                path.with_extension("renders.damaged").exists(),
                "{what} {k}"
            );
        }
    }

    /// Shards on one host asking at once: one flies, the others wait on its lock and read it.
    #[test]
    fn concurrent_requests_fly_once() {
        let dir = Scratch::new("concurrent");
        let s = spec(1_000_000_000);
        let results: Vec<(RenderedFlight, Fetched)> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..3)
                .map(|_| {
                    let (d, s) = (dir.path().to_path_buf(), s.clone());
                    scope.spawn(move || RenderCache::open(&d).unwrap().fly(s).unwrap())
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let flown = results.iter().filter(|(_, h)| *h == Fetched::Flown).count();
        let hits = results.iter().filter(|(_, h)| *h == Fetched::Hit).count();
        assert_eq!((flown, hits), (1, 2));
        for (f, _) in &results[1..] {
            same(&results[0].0, f);
        }
        assert_eq!(entries(dir.path(), ".renders"), 1);
    }
}
