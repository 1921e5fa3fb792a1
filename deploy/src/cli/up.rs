//! `waggle up FILE [--host NAME]`: starts and supervises the nodes a compose file places on
//! this host (every node without `--host`) — [`crate::launch::up`].

use anyhow::{Context, Result, bail};

use crate::compose::Compose;
use crate::launch::up::{UpDone, UpOptions, up};
use commands::up::UpArgs;

/// The session's secrets this invocation needs, from the directory the file names.
pub fn open_secrets(
    compose: &Compose,
    file: &std::path::Path,
    host: Option<&str>,
) -> Result<Option<bus::SessionSecrets>> {
    if !compose.auth {
        return Ok(None);
    }
    let dir = compose
        .secrets_dir(file)
        .context("an authenticated session needs secrets = DIR")?;
    let users = match host {
        Some(h) if !compose.hosts().iter().any(|x| x == h) => bail!(
            "host {h:?} is not in {} (it places nodes on: {})",
            file.display(),
            compose.hosts().join(", ")
        ),
        Some(h) => compose.users_on(h),
        None => compose.users(),
    };
    let secrets = bus::SessionSecrets::open(&dir, &users)
        .with_context(|| format!("opening the credentials of {}", file.display()))?;
    Ok(Some(secrets))
}

pub fn run(args: UpArgs) -> Result<()> {
    let compose = crate::compose::load(&args.file)?;
    let secrets = open_secrets(&compose, &args.file, args.host.as_deref())?;
    let json = args.launch.json;
    let ros2 = super::run::ros2_view(&args.launch);
    let opts = UpOptions {
        host: args.host,
        out: args.launch.out,
        bin_dir: args.launch.bin_dir,
        quiet: args.launch.quiet,
        live: args.launch.live,
        ros2,
        rss_every_s: args.launch.rss_every_s,
    };
    match up(&compose, secrets.as_ref(), &opts)? {
        UpDone::Supervised(done) => {
            if opts.out.is_none() && !json {
                println!("summary and logs in {}", done.out_dir.display());
            }
            super::run::report(&done.summary, json)
        }
        UpDone::Host { record, out_dir } => {
            let procs: Vec<String> = record
                .processes
                .iter()
                .map(|(n, p)| format!("{n} {} ({:.1} s CPU)", p.exit, p.cpu_s))
                .collect();
            println!(
                "host {} of session {}: {}; logs in {}",
                record.host,
                record.session,
                if procs.is_empty() {
                    "router only".to_string()
                } else {
                    procs.join(" · ")
                },
                out_dir.display()
            );
            for f in &record.faults {
                println!("  fault: {f}");
            }
            if record.interrupted {
                bail!("interrupted");
            }
            if !record.report_seen {
                bail!("the session ended without a mission report reaching this host");
            }
            Ok(())
        }
    }
}
