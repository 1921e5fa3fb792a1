//! Records gathered for a merge: one point's records over several directories (the shards of
//! a run, or one run), who made them, and what a merge accepts beyond one binary on one kind of
//! host. Shared by the link-study merge ([`crate::harness::study::merge`]) and the baselines
//! study's ([`crate::harness::study::baselines_run`]).

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

use anyhow::{Result, bail};
use serde::Serialize;

use crate::harness::runs::records::{Provenance, Recordable, scan};

/// What a merge accepts beyond a complete run of one binary on one kind of host.
#[derive(Debug, Clone, Copy, Default)]
pub struct MergeOptions {
    /// Write results from the trials recorded so far (an interrupted run); otherwise every trial
    /// must be recorded.
    pub partial: bool,
    /// Accept records made on different CPU models or renderers.
    pub mixed_hosts: bool,
}

/// Who made a study's records (`provenance.json`).
#[derive(Debug, Default, Serialize)]
pub struct Makers {
    pub(crate) versions: BTreeSet<String>,
    pub(crate) cpus: BTreeSet<String>,
    pub(crate) renderers: BTreeSet<String>,
}

/// One point's records over every source, by index; refuses a damaged record and a trial
/// recorded twice with different results.
pub fn gather_records<R: Recordable + PartialEq>(
    sources: &[PathBuf],
    rel: &str,
    requested: u64,
    makers: &mut Makers,
) -> Result<Vec<R>> {
    let mut records: BTreeMap<u64, R> = BTreeMap::new();
    for src in sources {
        let dir = src.join(rel);
        let found = scan::<R>(&dir, rel, requested)?;
        if let Some((path, why)) = found.damaged.first() {
            bail!(
                "damaged record {}: {why} (rerun that directory's run to repair it)",
                path.display()
            );
        }
        for (i, (r, p)) in found.records {
            let Provenance {
                version,
                cpu,
                renderer,
            } = p;
            makers.versions.insert(version);
            makers.cpus.insert(cpu);
            makers.renderers.insert(renderer);
            if let Some(was) = records.insert(i, r.clone())
                && was != r
            {
                bail!(
                    "trial {i} of {rel} is recorded twice with different results ({})",
                    dir.display()
                );
            }
        }
    }
    Ok(records.into_values().collect())
}

pub fn check_makers(makers: &Makers, options: MergeOptions) -> Result<()> {
    if makers.versions.len() > 1 {
        bail!(
            "the records were made by different waggle binaries ({}): results of different \
             versions are not merged",
            makers
                .versions
                .iter()
                .cloned()
                .collect::<Vec<_>>()
                .join(" | ")
        );
    }
    if !options.mixed_hosts && (makers.cpus.len() > 1 || makers.renderers.len() > 1) {
        bail!(
            "the records were made on different CPU models ({}) or renderers ({}); rendering may \
             differ between them, so the result may not equal a run on one machine kind \
             (--allow-mixed-hosts merges anyway)",
            makers.cpus.iter().cloned().collect::<Vec<_>>().join(" | "),
            makers
                .renderers
                .iter()
                .cloned()
                .collect::<Vec<_>>()
                .join(" | ")
        );
    }
    Ok(())
}
