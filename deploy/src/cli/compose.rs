//! `waggle compose CASE … --out FILE`: writes the session's compose file (which node runs on
//! which host with which arguments) and, for an authenticated session, its credentials
//! directory beside it ([`crate::compose`]).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;

use crate::compose::Compose;
use crate::compose::build::compose;
use crate::compose::place::HostPlacement;
use crate::compose::site::{HostIs, sites};

#[derive(Debug, Args)]
pub struct ComposeArgs {
    #[command(flatten)]
    session: super::run::SessionArgs,
    /// Place nodes on a host: `ROLE=HOST`, ROLE a process name (`sim`, `scheduler`,
    /// `performer`, `recorder`, `camera-O1`, `observer-O1`, `router`) or a glob of them
    /// (`camera-*`, `*-O2`); applied in order, later ones win. Unplaced nodes run on `local`.
    #[arg(long = "place", value_name = "ROLE=HOST")]
    place: Vec<HostPlacement>,
    /// Endpoint the router listens on and other hosts dial, e.g. `quic/192.168.1.10:7447`
    /// (mutual TLS; plain `tcp/` beyond loopback needs `--plain-tcp`; default
    /// `tcp/127.0.0.1:0`, one host); repeatable.
    #[arg(long = "router", value_name = "ENDPOINT")]
    router: Vec<String>,
    /// A site's own router on HOST, listening on ENDPOINT (repeat for more endpoints): the
    /// nodes of HOST and of the hosts it serves (`--site-serves`) dial it, and it dials the
    /// session's router — a chain of two routers, one link between the sites.
    #[arg(long = "site", value_name = "HOST=ENDPOINT")]
    site: Vec<HostIs>,
    /// HOST's nodes dial the site router on SITE (named by `--site SITE=…`).
    #[arg(long = "site-serves", value_name = "HOST=SITE")]
    site_serves: Vec<HostIs>,
    /// An existing certificate authority (an institution's) to issue the session's
    /// certificates instead of a new CA of the session's own: its certificate (PEM). Needs
    /// `--ca-key`. Certificates then expire with the session or the CA, whichever is first.
    #[arg(long, value_name = "FILE", requires = "ca_key")]
    ca_cert: Option<PathBuf>,
    /// That CA's private key (PEM, readable by its owner only): read to sign, never copied.
    #[arg(long, value_name = "FILE", requires = "ca_cert")]
    ca_key: Option<PathBuf>,
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
    c.sites = sites(&args.site, &args.site_serves)?;
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
    let ca = match (&args.ca_cert, &args.ca_key) {
        (Some(cert), Some(key)) if c.auth => Some(bus::tls::ExistingCa::read(cert, key)?),
        (Some(_), _) => bail!("--ca-cert: an open session (--no-auth) has no certificates"),
        _ => None,
    };
    if c.auth {
        bus::SessionSecrets::create_kept_signed_by(
            &secrets,
            &c.users(),
            bus::auth::CERTIFICATE_VALIDITY,
            ca.as_ref(),
        )
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
    for site in &c.sites {
        println!(
            "site router on {} listening on {}, serving {}",
            site.host,
            site.listen.join(", "),
            site.hosts().cloned().collect::<Vec<_>>().join(", ")
        );
    }
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
