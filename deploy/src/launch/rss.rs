//! `--rss-every-s N`: the resident memory (`VmRSS`, kB) of every process of the run — each
//! local child and the launcher itself — sampled each time sim time crosses a multiple of N
//! seconds, one row per sample in `DIR/rss.csv`. A measurement only: it reads
//! `/proc/PID/status` and nothing reads it back, so no decision and no other output depends
//! on it; its values (like CPU times) are not reproducible byte for byte.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use super::process::Proc;

/// The file the samples go to, in the run directory.
pub const RSS_FILE: &str = "rss.csv";
/// The launcher's own column.
pub const LAUNCHER_COLUMN: &str = "launcher";

/// Samples every process's resident memory at each multiple of a sim-time period.
pub struct RssSampler {
    every_ns: u64,
    /// The next multiple of the period due (0: the clock's first tick).
    next_ns: u64,
    /// Column names, sorted: every child's and the launcher's.
    columns: Vec<String>,
    out: BufWriter<File>,
    path: PathBuf,
}

impl RssSampler {
    /// Creates `out_dir/rss.csv` for the children `procs` and writes its header:
    /// `sim_s,<process>,…`, the processes sorted by name.
    pub fn create(out_dir: &Path, every_s: u32, procs: &[Proc]) -> Result<Self> {
        anyhow::ensure!(every_s > 0, "--rss-every-s must be at least 1 s");
        let mut columns: Vec<String> = procs.iter().map(|p| p.name.clone()).collect();
        columns.push(LAUNCHER_COLUMN.to_string());
        columns.sort();
        columns.dedup();
        let path = out_dir.join(RSS_FILE);
        let file = File::create(&path).with_context(|| format!("creating {}", path.display()))?;
        let mut out = BufWriter::new(file);
        writeln!(out, "sim_s,{}", columns.join(","))
            .and_then(|()| out.flush())
            .with_context(|| format!("writing {}", path.display()))?;
        Ok(Self {
            every_ns: u64::from(every_s) * proto::NS_PER_S,
            next_ns: 0,
            columns,
            out,
            path,
        })
    }

    /// Writes a row when sim time `now_ns` (the clock has started) has reached the next
    /// multiple of the period: that multiple in seconds, then each process's VmRSS in kB
    /// (empty once it has exited). Several multiples crossed at once give one row, the
    /// latest's.
    pub fn sample(&mut self, now_ns: u64, procs: &[Proc]) -> Result<()> {
        if now_ns < self.next_ns {
            return Ok(());
        }
        let at_ns = now_ns / self.every_ns * self.every_ns;
        self.next_ns = at_ns + self.every_ns;
        let mut row = format!("{}", at_ns / proto::NS_PER_S);
        for name in &self.columns {
            let kb = if name == LAUNCHER_COLUMN {
                own_rss_kb()
            } else {
                procs
                    .iter()
                    .find(|p| p.name == *name && p.running())
                    .and_then(|p| rss_kb(p.child.id()))
            };
            row.push(',');
            if let Some(kb) = kb {
                row.push_str(&kb.to_string());
            }
        }
        writeln!(self.out, "{row}")
            .and_then(|()| self.out.flush())
            .with_context(|| format!("writing {}", self.path.display()))
    }
}

/// VmRSS of process `pid`, kB (`None`: gone, or a zombie without memory).
fn rss_kb(pid: u32) -> Option<u64> {
    procfs::process::Process::new(i32::try_from(pid).ok()?)
        .ok()?
        .status()
        .ok()?
        .vmrss
}

/// The launcher's own VmRSS, kB.
fn own_rss_kb() -> Option<u64> {
    procfs::process::Process::myself()
        .ok()?
        .status()
        .ok()?
        .vmrss
}

/// The rows of an `rss.csv`: the header's process names, then per row the sim second and
/// each process's kB (`None`: not running then).
pub type RssTable = (Vec<String>, Vec<(u64, Vec<Option<u64>>)>);

/// Reads an `rss.csv` back (tests and reports).
pub fn read(path: &Path) -> Result<RssTable> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut lines = text.lines();
    let header = lines.next().context("rss.csv is empty")?;
    let mut names = header.split(',');
    anyhow::ensure!(names.next() == Some("sim_s"), "rss.csv header: {header}");
    let names: Vec<String> = names.map(str::to_string).collect();
    let mut rows = Vec::new();
    for line in lines {
        let mut cells = line.split(',');
        let sim_s: u64 = cells
            .next()
            .unwrap_or_default()
            .parse()
            .with_context(|| format!("rss.csv row {line:?}"))?;
        let values: Vec<Option<u64>> = cells.map(|c| c.parse().ok()).collect();
        anyhow::ensure!(
            values.len() == names.len(),
            "rss.csv row {line:?} has {} values for {} processes",
            values.len(),
            names.len()
        );
        rows.push((sim_s, values));
    }
    Ok((names, rows))
}
