//! Where a process's Zenoh session listens and what it connects to.

use crate::auth::Credentials;
use crate::error::BusError;

/// The endpoint options shared by every Waggle binary.
#[derive(Debug, Clone, Default, PartialEq, Eq, clap::Args)]
pub struct Endpoints {
    /// Zenoh endpoint to connect to (e.g. `tcp/127.0.0.1:7447`); repeatable.
    #[arg(long = "connect", value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// Zenoh endpoint to listen on (default `tcp/127.0.0.1:0`: loopback, any free port);
    /// repeatable. Use e.g. `tcp/0.0.0.0:7447` for multi-host runs.
    #[arg(long = "listen", value_name = "ENDPOINT")]
    pub listen: Vec<String>,
}

impl Endpoints {
    /// The listen endpoints that are not on loopback (`tcp/0.0.0.0:7447`, a LAN address, …).
    pub fn non_loopback_listeners(&self) -> Vec<String> {
        self.listen
            .iter()
            .filter(|e| !is_loopback_endpoint(e))
            .cloned()
            .collect()
    }

    /// The command-line arguments that reproduce these endpoints in a child process.
    pub fn to_args(&self) -> Vec<String> {
        let mut out = Vec::new();
        for c in &self.connect {
            out.push("--connect".into());
            out.push(c.clone());
        }
        for l in &self.listen {
            out.push("--listen".into());
            out.push(l.clone());
        }
        out
    }
}

/// True for a `proto/host:port` endpoint whose host is a loopback address or `localhost`.
pub fn is_loopback_endpoint(endpoint: &str) -> bool {
    let Some((_, locator)) = endpoint.split_once('/') else {
        return false;
    };
    // Drop any `#config` or `?metadata` suffix, then the port.
    let locator = locator.split(['#', '?']).next().unwrap_or("");
    let host = match locator.rsplit_once(':') {
        Some((h, _)) => h,
        None => locator,
    };
    let host = host.trim_start_matches('[').trim_end_matches(']');
    host == "localhost"
        || host
            .parse::<std::net::IpAddr>()
            .is_ok_and(|ip| ip.is_loopback())
}

/// How long a client keeps dialling the session's router at start-up, ms (the nodes' default
/// start-up timeout).
pub const CLIENT_CONNECT_TIMEOUT_MS: u64 = 120_000;

/// The loopback listener used when no `--listen` is given.
pub const LOOPBACK_ANY_PORT: &str = "tcp/127.0.0.1:0";

/// The configuration shared by every mode: multicast scouting off (peers find each other
/// through the endpoints and gossip), the given connect endpoints.
fn base(mode: &str, endpoints: &Endpoints, listen: &[String]) -> Result<zenoh::Config, BusError> {
    let mut config = zenoh::Config::default();
    set(&mut config, "mode", format!("\"{mode}\""))?;
    if mode == "client" {
        // The hosts of a session start in any order: a client keeps dialling the router (every
        // second) for as long as a process waits for its peers at start-up, instead of giving
        // up at once when the router is not up yet.
        set(
            &mut config,
            "connect/timeout_ms",
            CLIENT_CONNECT_TIMEOUT_MS.to_string(),
        )?;
        set(
            &mut config,
            "connect/retry",
            "{ period_init_ms: 250, period_max_ms: 1000, period_increase_factor: 2 }".into(),
        )?;
    }
    set(&mut config, "scouting/multicast/enabled", "false".into())?;
    let single_stream =
        |list: &[String]| -> Vec<String> { list.iter().map(|e| single_stream_quic(e)).collect() };
    set(
        &mut config,
        "listen/endpoints",
        json_list(&single_stream(listen)),
    )?;
    set(
        &mut config,
        "connect/endpoints",
        json_list(&single_stream(&endpoints.connect)),
    )?;
    Ok(config)
}

/// A `quic/` endpoint with `multistream=0` added unless it sets it: in Zenoh 1.10.2 the default
/// (`auto`: one QUIC stream per priority) delivered the declarations but never the data of a
/// Waggle session (every node waited for its first message; `tests/quic.rs` in `libs/bus`
/// and the golden runs over `quic/` pass with one stream). Other endpoints are unchanged.
pub fn single_stream_quic(endpoint: &str) -> String {
    if !endpoint.starts_with("quic/") || endpoint.contains("multistream=") {
        return endpoint.to_string();
    }
    // Metadata (`?a=b;c=d`) comes before the link configuration (`#…`).
    let (address, config) = endpoint
        .split_once('#')
        .map_or((endpoint, None), |(a, c)| (a, Some(c)));
    let sep = if address.contains('?') { ';' } else { '?' };
    match config {
        Some(c) => format!("{address}{sep}multistream=0#{c}"),
        None => format!("{address}{sep}multistream=0"),
    }
}

fn set(config: &mut zenoh::Config, key: &str, value: String) -> Result<(), BusError> {
    config
        .insert_json5(key, &value)
        .map_err(|e| BusError::Config(format!("{key} = {value}: {e}")))
}

/// The listen endpoints, loopback on any port when none are given.
fn listen_or_loopback(endpoints: &Endpoints) -> Vec<String> {
    if endpoints.listen.is_empty() {
        vec![LOOPBACK_ANY_PORT.to_string()]
    } else {
        endpoints.listen.clone()
    }
}

/// A Zenoh configuration for one Waggle process in peer mode (the open bus: `--no-auth` runs
/// and processes started by hand), listening on loopback unless told otherwise.
/// Every key expression in `deny` is closed by a Zenoh access-control list on every link of the
/// process: its subscriptions there never leave it and publications there never enter it.
pub fn config(endpoints: &Endpoints, deny: &[String]) -> Result<zenoh::Config, BusError> {
    let mut config = base("peer", endpoints, &listen_or_loopback(endpoints))?;
    deny_on_every_link(&mut config, deny)?;
    Ok(config)
}

/// Closes every key expression of `deny` with an access-control list on every link.
pub fn deny_on_every_link(config: &mut zenoh::Config, deny: &[String]) -> Result<(), BusError> {
    if deny.is_empty() {
        return Ok(());
    }
    for k in deny {
        zenoh::key_expr::KeyExpr::try_from(k.as_str())
            .map_err(|e| BusError::Config(format!("--deny {k:?}: {e}")))?;
    }
    let acl = format!(
        r#"{{
            enabled: true,
            default_permission: "allow",
            rules: [{{
                id: "deny",
                key_exprs: {keys},
                messages: ["put", "delete", "declare_subscriber", "query", "reply"],
                flows: ["egress", "ingress"],
                permission: "deny",
            }}],
            subjects: [{{ id: "every-link", link_protocols: ["tcp", "quic"] }}],
            policies: [{{ rules: ["deny"], subjects: ["every-link"] }}],
        }}"#,
        keys = json_list(deny)
    );
    set(config, "access_control", acl)
}

/// A node of an authenticated session: a Zenoh client of the session's router (it listens on
/// nothing, so nothing can connect to it), authenticating as `credentials`.
pub fn client_config(
    endpoints: &Endpoints,
    credentials: &Credentials,
) -> Result<zenoh::Config, BusError> {
    if endpoints.connect.is_empty() {
        return Err(BusError::Config(
            "an authenticated node needs --connect to the session's router".into(),
        ));
    }
    let mut config = base("client", endpoints, &[])?;
    with_tls(
        &mut config,
        endpoints,
        &[],
        credentials.tls.as_ref(),
        &credentials.user,
    )?;
    set(
        &mut config,
        "transport/auth/usrpwd/user",
        serde_json_string(&credentials.user),
    )?;
    set(
        &mut config,
        "transport/auth/usrpwd/password",
        serde_json_string(credentials.password()),
    )?;
    Ok(config)
}

/// The session's router (hosted by the launcher): accepts only the users of `dictionary` and
/// enforces `acl` (an `access_control` section, see [`crate::access::router_acl`]). Its Zenoh
/// id is `zid` ([`crate::access::session_router_zid`]), by which sites' routers know it.
pub fn router_config(
    endpoints: &Endpoints,
    dictionary: &std::path::Path,
    acl: &str,
    zid: &str,
) -> Result<zenoh::Config, BusError> {
    let listen = listen_or_loopback(endpoints);
    let mut config = base("router", endpoints, &listen)?;
    let tls = dictionary
        .parent()
        .map(|dir| crate::tls::cert_files(dir, crate::tls::ROUTER_CERT_NAME))
        .filter(crate::tls::TlsFiles::exist);
    with_tls(
        &mut config,
        endpoints,
        &listen,
        tls.as_ref(),
        crate::tls::ROUTER_CERT_NAME,
    )?;
    set(
        &mut config,
        "transport/auth/usrpwd/dictionary_file",
        serde_json_string(&dictionary.display().to_string()),
    )?;
    set(&mut config, "access_control", acl.to_string())?;
    set(&mut config, "id", serde_json_string(zid))?;
    Ok(config)
}

/// A site's router (hosted by the launcher of its host): a router that dials the session's
/// router (`endpoints.connect`) authenticating as `credentials` (its host's launcher, user and
/// certificate), and serves the processes of its hosts (`endpoints.listen`), accepting only the
/// users of `dictionary` and enforcing `acl` (built with the session router's id as upstream).
pub fn site_router_config(
    endpoints: &Endpoints,
    credentials: &Credentials,
    dictionary: &std::path::Path,
    acl: &str,
) -> Result<zenoh::Config, BusError> {
    if endpoints.connect.is_empty() {
        return Err(BusError::Config(
            "a site's router needs the session's router to dial".into(),
        ));
    }
    let listen = listen_or_loopback(endpoints);
    let mut config = base("router", endpoints, &listen)?;
    with_tls(
        &mut config,
        endpoints,
        &listen,
        credentials.tls.as_ref(),
        &credentials.user,
    )?;
    for (key, value) in [
        ("user", &credentials.user),
        ("password", &credentials.password().to_string()),
        ("dictionary_file", &dictionary.display().to_string()),
    ] {
        set(
            &mut config,
            &format!("transport/auth/usrpwd/{key}"),
            serde_json_string(value),
        )?;
    }
    set(&mut config, "access_control", acl.to_string())?;
    Ok(config)
}

/// True for an endpoint of Zenoh's QUIC link (always TLS).
fn is_quic(endpoint: &str) -> bool {
    endpoint.starts_with("quic/")
}

/// Mutual TLS with the session's certificates (`crate::tls`) when any endpoint this process
/// listens on or dials is `quic/`: it presents `files`' certificate, trusts only the session's
/// CA, and requires the peer's certificate too. Names are not checked against addresses (the
/// session CA, not DNS, is what identifies a peer), and a link closes when a certificate
/// expires. A `quic/` endpoint without certificates is refused naming `who`.
fn with_tls(
    config: &mut zenoh::Config,
    endpoints: &Endpoints,
    listen: &[String],
    files: Option<&crate::tls::TlsFiles>,
    who: &str,
) -> Result<(), BusError> {
    let dials = endpoints.connect.iter().any(|e| is_quic(e));
    let listens = listen.iter().any(|e| is_quic(e));
    if !dials && !listens {
        return Ok(());
    }
    let files = files.ok_or_else(|| {
        BusError::Config(format!(
            "{who}: a quic/ endpoint needs the session's certificates (ca.pem, \
             {who}.cert.pem, {who}.key.pem beside the credentials)"
        ))
    })?;
    let path = |p: &std::path::Path| serde_json_string(&p.display().to_string());
    let mut settings = vec![
        ("root_ca_certificate".to_string(), path(&files.ca)),
        ("enable_mtls".to_string(), "true".to_string()),
        ("verify_name_on_connect".to_string(), "false".to_string()),
        ("close_link_on_expiration".to_string(), "true".to_string()),
    ];
    // The same certificate for the links it accepts and those it opens.
    for (side, used) in [("listen", listens), ("connect", dials)] {
        if used {
            settings.push((format!("{side}_certificate"), path(&files.cert)));
            settings.push((format!("{side}_private_key"), path(&files.key)));
        }
    }
    for (key, value) in settings {
        set(config, &format!("transport/link/tls/{key}"), value)?;
    }
    Ok(())
}

/// A client of an open router (`--no-auth`).
pub fn open_client_config(endpoints: &Endpoints) -> Result<zenoh::Config, BusError> {
    if endpoints.connect.is_empty() {
        return Err(BusError::Config(
            "a client node needs --connect to the session's router".into(),
        ));
    }
    base("client", endpoints, &[])
}

/// An open router (`--no-auth`): same topology, no authentication, no access control.
pub fn open_router_config(endpoints: &Endpoints) -> Result<zenoh::Config, BusError> {
    base("router", endpoints, &listen_or_loopback(endpoints))
}

fn serde_json_string(s: &str) -> String {
    json_list(&[s.to_string()])
        .trim_start_matches('[')
        .trim_end_matches(']')
        .to_string()
}

pub(crate) fn json_list(items: &[String]) -> String {
    let quoted: Vec<String> = items
        .iter()
        .map(|s| format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\"")))
        .collect();
    format!("[{}]", quoted.join(","))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zenoh_tcp_links_linger_one_second_at_most() {
        // The value Zenoh's TCP links were compiled with (.cargo/config.toml): zenoh-link-tcp
        // reads the same variable with option_env!, so this crate sees what it saw. Without it,
        // a router dropping a dead host's links blocks a thread per link for 10 s (the lease).
        assert_eq!(
            option_env!("TCP_LINGER_TIMEOUT"),
            Some("1"),
            "build through cargo with the workspace's .cargo/config.toml"
        );
    }

    #[test]
    fn default_config_listens_on_loopback_with_multicast_off() {
        let c = config(&Endpoints::default(), &[]).unwrap();
        let listen = c.get_json("listen/endpoints").unwrap();
        assert!(listen.contains("tcp/127.0.0.1:0"), "{listen}");
        assert_eq!(c.get_json("scouting/multicast/enabled").unwrap(), "false");
        assert_eq!(c.get_json("mode").unwrap(), "\"peer\"");
    }

    #[test]
    fn quic_endpoints_get_one_stream_and_others_are_left_alone() {
        assert_eq!(
            single_stream_quic("quic/127.0.0.1:7447"),
            "quic/127.0.0.1:7447?multistream=0"
        );
        assert_eq!(
            single_stream_quic("quic/h:1?rel=1#x=y"),
            "quic/h:1?rel=1;multistream=0#x=y"
        );
        assert_eq!(
            single_stream_quic("quic/h:1?multistream=1"),
            "quic/h:1?multistream=1"
        );
        assert_eq!(single_stream_quic("tcp/h:1"), "tcp/h:1");
    }

    #[test]
    fn endpoints_round_trip_through_child_arguments() {
        let e = Endpoints {
            connect: vec!["tcp/127.0.0.1:7447".into()],
            listen: vec!["tcp/127.0.0.1:7448".into()],
        };
        assert_eq!(
            e.to_args(),
            [
                "--connect",
                "tcp/127.0.0.1:7447",
                "--listen",
                "tcp/127.0.0.1:7448"
            ]
        );
        let c = config(&e, &[]).unwrap();
        assert!(c.get_json("connect/endpoints").unwrap().contains("7447"));
        assert!(c.get_json("listen/endpoints").unwrap().contains("7448"));
    }

    #[test]
    fn a_malformed_endpoint_is_a_typed_error() {
        let e = Endpoints {
            connect: vec!["not an endpoint".into()],
            listen: vec![],
        };
        assert!(matches!(config(&e, &[]), Err(BusError::Config(_))));
        let bad_key = config(&Endpoints::default(), &["a//b".to_string()]);
        assert!(matches!(bad_key, Err(BusError::Config(m)) if m.contains("a//b")));
    }

    #[test]
    fn loopback_endpoints_are_told_apart() {
        for e in [
            "tcp/127.0.0.1:7447",
            "tcp/localhost:1",
            "tcp/[::1]:7447",
            "tcp/127.1.2.3:0",
        ] {
            assert!(is_loopback_endpoint(e), "{e}");
        }
        for e in [
            "tcp/0.0.0.0:7447",
            "tcp/192.168.1.4:7447",
            "tcp/[::]:7447",
            "nonsense",
        ] {
            assert!(!is_loopback_endpoint(e), "{e}");
        }
        let e = Endpoints {
            connect: vec![],
            listen: vec!["tcp/127.0.0.1:1".into(), "tcp/0.0.0.0:2".into()],
        };
        assert_eq!(e.non_loopback_listeners(), ["tcp/0.0.0.0:2"]);
    }

    #[test]
    fn a_deny_list_becomes_an_access_control_list() {
        let c = config(&Endpoints::default(), &["waggle/s/sim/**".to_string()]).unwrap();
        let acl = c.get_json("access_control").unwrap();
        assert!(acl.contains("waggle/s/sim/**"), "{acl}");
        assert!(acl.contains("declare_subscriber"), "{acl}");
        assert!(c.get_json("access_control/enabled").unwrap() == "true");
        let none = config(&Endpoints::default(), &[]).unwrap();
        assert_eq!(none.get_json("access_control/enabled").unwrap(), "false");
    }
}
