//! Where a process's Zenoh session listens and what it connects to.

use crate::bus::BusError;

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

/// The loopback listener used when no `--listen` is given.
pub const LOOPBACK_ANY_PORT: &str = "tcp/127.0.0.1:0";

/// A Zenoh configuration for one Waggle process: peer mode, multicast scouting off (peers find
/// each other through the endpoints and gossip), listening on loopback unless told otherwise.
/// Every key expression in `deny` is closed by a Zenoh access-control list on every link of the
/// process: its subscriptions there never leave it and publications there never enter it.
pub fn config(endpoints: &Endpoints, deny: &[String]) -> Result<zenoh::Config, BusError> {
    let listen = if endpoints.listen.is_empty() {
        vec![LOOPBACK_ANY_PORT.to_string()]
    } else {
        endpoints.listen.clone()
    };
    let mut config = zenoh::Config::default();
    let set = |config: &mut zenoh::Config, key: &str, value: String| {
        config
            .insert_json5(key, &value)
            .map_err(|e| BusError::Config(format!("{key} = {value}: {e}")))
    };
    set(&mut config, "mode", "\"peer\"".into())?;
    set(&mut config, "scouting/multicast/enabled", "false".into())?;
    set(&mut config, "listen/endpoints", json_list(&listen))?;
    set(
        &mut config,
        "connect/endpoints",
        json_list(&endpoints.connect),
    )?;
    if !deny.is_empty() {
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
                subjects: [{{ id: "every-link", link_protocols: ["tcp"] }}],
                policies: [{{ rules: ["deny"], subjects: ["every-link"] }}],
            }}"#,
            keys = json_list(deny)
        );
        set(&mut config, "access_control", acl)?;
    }
    Ok(config)
}

fn json_list(items: &[String]) -> String {
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
    fn default_config_listens_on_loopback_with_multicast_off() {
        let c = config(&Endpoints::default(), &[]).unwrap();
        let listen = c.get_json("listen/endpoints").unwrap();
        assert!(listen.contains("tcp/127.0.0.1:0"), "{listen}");
        assert_eq!(c.get_json("scouting/multicast/enabled").unwrap(), "false");
        assert_eq!(c.get_json("mode").unwrap(), "\"peer\"");
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
