//! `waggle compose CASE … --out FILE`: writes the session's compose file (which node runs on
//! which host with which arguments) and, for an authenticated session, its credentials
//! directory beside it ([`crate::compose`]).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;

use crate::compose::Compose;
use crate::compose::build::compose;
use crate::compose::place::HostPlacement;

#[derive(Debug, Args)]
pub struct ComposeArgs {
    #[command(flatten)]
    session: super::run::SessionArgs,
    /// Place nodes on a host: `ROLE=HOST`, ROLE a process name (`sim`, `scheduler`,
    /// `performer`, `recorder`, `camera-O1`, `observer-O1`, `router`) or a glob of them
    /// (`camera-*`, `*-O2`); applied in order, later ones win. Unplaced nodes run on `local`.
    #[arg(long = "place", value_name = "ROLE=HOST")]
    place: Vec<HostPlacement>,
    /// Endpoint the router listens on and other hosts dial, e.g. `tcp/192.168.1.10:7447`
    /// (default `tcp/127.0.0.1:0`, one host); repeatable.
    #[arg(long = "router", value_name = "ENDPOINT")]
    router: Vec<String>,
    /// The compose file to write. Its credentials go to FILE's name with `.secrets` (a private
    /// directory; `waggle bundle FILE --host NAME` extracts what one host needs).
    #[arg(long)]
    out: PathBuf,
}

/// The credentials directory of compose file `file`: `session.toml` → `session.secrets`.
pub fn secrets_dir_of(file: &Path) -> PathBuf {
    file.with_extension("secrets")
}

pub fn run(args: ComposeArgs) -> Result<()> {
    let (case, modality, opts) = args.session.options()?;
    let mut options = opts.compose_options(&case, modality)?;
    options.placements = args.place;
    options.router_listen = args.router;
    let mut c = compose(&case, &options)?;
    let secrets = secrets_dir_of(&args.out);
    if secrets == args.out {
        bail!(
            "--out {}: give the compose file an extension (e.g. .toml)",
            args.out.display()
        );
    }
    if c.auth {
        c.secrets = Some(PathBuf::from(
            secrets
                .file_name()
                .context("the compose file has no name")?,
        ));
    }
    c.check().context("checking the composed session")?;
    if c.auth {
        bus::SessionSecrets::create_kept(&secrets, &c.users())
            .context("writing the session's credentials")?;
    }
    std::fs::write(&args.out, c.to_toml()?)
        .with_context(|| format!("writing {}", args.out.display()))?;
    describe(&c, &args.out, c.auth.then_some(secrets.as_path()));
    Ok(())
}

/// Which host runs what, and the command to run on each.
fn describe(c: &Compose, file: &Path, secrets: Option<&Path>) {
    println!(
        "session {} ({} nodes) written to {}",
        c.session,
        c.nodes.len(),
        file.display()
    );
    if let Some(s) = secrets {
        println!(
            "credentials in {} (private; `waggle bundle {} --host NAME --out DIR` copies the \
             file and only that host's credentials, for that host)",
            s.display(),
            file.display()
        );
    }
    println!(
        "router on {} listening on {}",
        c.router.host,
        c.router.listen.join(", ")
    );
    for host in c.hosts() {
        let nodes: Vec<String> = c.nodes_on(&host).map(|n| n.role.name()).collect();
        println!(
            "  {host}: {}   →   waggle up {} --host {host}",
            if nodes.is_empty() {
                "(router only)".to_string()
            } else {
                nodes.join(" ")
            },
            file.display()
        );
    }
}
