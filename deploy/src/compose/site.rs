//! `--site HOST=ENDPOINT` and `--site-serves HOST=SITE`: a router per site, the chain of two
//! routers a multi-site session needs (a site's hosts talk to their own router, one link
//! crosses to the session's router).

use anyhow::{Result, bail};

use super::SiteRouter;

pub use commands::assign::HostIs;

/// The sites of `--site HOST=ENDPOINT` (a router on HOST listening there; repeat for more
/// endpoints) and `--site-serves HOST=SITE` (HOST's nodes dial the router on SITE), in the
/// order the sites were first named.
pub fn sites(listen: &[HostIs], serves: &[HostIs]) -> Result<Vec<SiteRouter>> {
    let mut out: Vec<SiteRouter> = Vec::new();
    for l in listen {
        match out.iter_mut().find(|s| s.host == l.host) {
            Some(site) => site.listen.push(l.value.clone()),
            None => out.push(SiteRouter {
                host: l.host.clone(),
                listen: vec![l.value.clone()],
                serves: Vec::new(),
            }),
        }
    }
    for s in serves {
        let Some(site) = out.iter_mut().find(|x| x.host == s.value) else {
            bail!(
                "--site-serves {}={}: no --site {}=ENDPOINT names a router on {}",
                s.host,
                s.value,
                s.value,
                s.value
            );
        };
        if !site.serves.contains(&s.host) {
            site.serves.push(s.host.clone());
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn host_is(s: &str) -> HostIs {
        s.parse().unwrap()
    }

    #[test]
    fn sites_gather_their_endpoints_and_hosts() {
        let got = sites(
            &[
                host_is("b=quic/10.0.0.2:7447"),
                host_is("d=quic/10.0.1.2:7447"),
                host_is("b=tcp/127.0.0.1:7448"),
            ],
            &[host_is("c=b"), host_is("e=b"), host_is("c=b")],
        )
        .unwrap();
        assert_eq!(got.len(), 2);
        assert_eq!(
            got[0],
            SiteRouter {
                host: "b".into(),
                listen: vec!["quic/10.0.0.2:7447".into(), "tcp/127.0.0.1:7448".into()],
                serves: vec!["c".into(), "e".into()],
            }
        );
        assert!(got[1].serves.is_empty());
    }

    #[test]
    fn bad_site_options_name_themselves() {
        for bad in ["b", "=x", "b/c=x", "b="] {
            let e = bad.parse::<HostIs>().unwrap_err();
            assert!(e.to_string().contains(bad), "{e}");
        }
        let e = sites(&[host_is("b=quic/1.2.3.4:1")], &[host_is("c=z")]).unwrap_err();
        assert!(e.to_string().contains("c=z"), "{e}");
    }
}
