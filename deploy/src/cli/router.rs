//! `waggle router`: the session's Zenoh router on its own (a host that runs no node, or a
//! router started before the hosts) — [`crate::launch::router`].

use anyhow::{Result, bail};

use crate::launch::router;
use commands::router::RouterArgs;

pub fn run(args: RouterArgs) -> Result<()> {
    crate::launch::own_log::to_stderr();
    let stop = bus::on_stop_signal();
    let (session, config, listen) = match &args.compose {
        Some(file) => {
            let mut c = crate::compose::load(file)?;
            if args.no_auth && c.auth {
                bail!("--no-auth: {} is an authenticated session", file.display());
            }
            if !args.listen.is_empty() {
                c.router.listen = args.listen.clone();
            }
            let secrets = super::up::open_secrets(&c, file, Some(&c.router.host.clone()))?;
            let config = router::config(&c, secrets.as_ref())?;
            (c.session, config, c.router.listen)
        }
        None => {
            if !args.no_auth {
                bail!(
                    "an authenticated router needs the session's compose file (--compose FILE) \
                     for its users and access list; --no-auth --session S serves an open \
                     loopback router"
                );
            }
            let Some(session) = args.session.clone() else {
                bail!("--no-auth without --compose needs --session S");
            };
            if args.listen.is_empty() {
                bail!("--listen ENDPOINT is required without --compose");
            }
            let endpoints = bus::Endpoints {
                connect: Vec::new(),
                listen: args.listen.clone(),
            };
            let config = router::open_config(&session, &endpoints)?;
            (session, config, args.listen)
        }
    };
    router::serve(&session, config, &listen, &stop)
}
