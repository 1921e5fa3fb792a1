//! What `rmw_zenoh` (ROS 2 Jazzy's Zenoh middleware, `ros2/rmw_zenoh`, its `docs/design.md`)
//! puts on Zenoh for a publisher, as pure functions: the data key expression, the liveliness
//! tokens of the node and of each publisher, the QoS text inside a token, and the attachment of
//! every sample. [`crate::live`] does the Zenoh side.
//!
//! - **Data key:** `<domain>/<topic without its leading slash>/<pkg>::msg::dds_::<Type>_/<RIHS01
//!   type hash>`, e.g. `0/O1/events/event_camera_msgs::msg::dds_::EventPacket_/RIHS01_…`.
//! - **Liveliness token:** `@ros2_lv/<domain>/<session id>/<node id>/<entity id>/<kind>/<enclave>/
//!   <namespace>/<node name>` for a node (`NN`, entity id = node id), followed by
//!   `/<topic>/<dds type>/<type hash>/<qos>` for a publisher (`MP`). Names are mangled (`/` →
//!   `%`, so the default enclave and namespace `/` are `%`); the session id is the Zenoh
//!   session's id in hex.
//! - **QoS text:** `<reliability>:<durability>:<history>,<depth>:<deadline s>,<ns>:<lifespan
//!   s>,<ns>:<liveliness>,<lease s>,<ns>`, each field the `rmw_qos_*` enum value, left empty when
//!   it equals ROS's default profile (reliable, volatile, keep last 10, durations and liveliness
//!   unset): a volatile topic is `::,:,:,:,,`, a latched one (`/tf_static`) `:1:,1:,:,:,,`.
//! - **Attachment:** the Zenoh serializer's encoding of (`sequence_number: i64`,
//!   `source_timestamp: i64`, `source_gid: [u8; 16]`): two little-endian 8-byte integers, then
//!   the GID as a sequence (its length 16 as one LEB128 byte, then the bytes) — 33 bytes. The
//!   sequence number counts each publisher's samples from 1.
//!
//! One difference: `rmw_zenoh` derives an entity's GID from an XXH3-128 hash of its token; ours
//! is the first 16 bytes of the token's SHA-256 (a GID is opaque to every reader: it only has
//! to be unique and stable).

use sha2::{Digest, Sha256};

use crate::bag::QosProfile;
use crate::definitions::type_hash;
use crate::error::Ros2Error;

/// The liveliness tokens' key space.
pub const ADMIN_SPACE: &str = "@ros2_lv";
/// Bytes of an attachment.
pub const ATTACHMENT_LEN: usize = 33;

/// `pkg/msg/Type` → `pkg::msg::dds_::Type_` (the type name on the wire and in tokens).
///
/// # Errors
///
/// A name that is not `pkg/msg/Type`.
pub fn dds_type_name(type_name: &str) -> Result<String, Ros2Error> {
    match type_name.split('/').collect::<Vec<_>>()[..] {
        [pkg, "msg", ty] if !pkg.is_empty() && !ty.is_empty() => {
            Ok(format!("{pkg}::msg::dds_::{ty}_"))
        }
        _ => Err(Ros2Error::Live {
            reason: format!("{type_name:?} is not a message type `pkg/msg/Type`"),
        }),
    }
}

/// `/` → `%` (a name inside a token is one chunk of the key expression).
pub fn mangle(name: &str) -> String {
    name.replace('/', "%")
}

/// Checks a ROS name made of `/`-separated tokens of letters, digits and underscores (not
/// starting with a digit), as ROS and a Zenoh key both accept.
fn check_name(what: &str, name: &str, absolute: bool) -> Result<(), Ros2Error> {
    let bad = |why: &str| Ros2Error::Live {
        reason: format!("{what} {name:?}: {why}"),
    };
    let rest = if absolute {
        name.strip_prefix('/')
            .ok_or_else(|| bad("must start with /"))?
    } else {
        name
    };
    for token in rest.split('/') {
        let mut chars = token.chars();
        match chars.next() {
            None => return Err(bad("has an empty part")),
            Some(c) if c.is_ascii_digit() => return Err(bad("a part starts with a digit")),
            _ => {}
        }
        if !token.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(bad("only letters, digits and _ between slashes"));
        }
    }
    Ok(())
}

/// The data key expression of `topic` (`/O1/events`) of type `type_name` in `domain`.
///
/// # Errors
///
/// A topic that is not a valid absolute ROS name, or a type the crate has no definition of.
pub fn topic_key(domain: u32, topic: &str, type_name: &str) -> Result<String, Ros2Error> {
    check_name("topic", topic, true)?;
    Ok(format!(
        "{domain}/{}/{}/{}",
        topic.trim_matches('/'),
        dds_type_name(type_name)?,
        type_hash(type_name)?
    ))
}

/// The QoS text of a token (fields equal to ROS's default profile left empty).
pub fn qos_text(qos: QosProfile) -> String {
    // rmw_qos_durability_policy_e: TRANSIENT_LOCAL = 1 (VOLATILE = 2 is the default); a latched
    // topic keeps its last sample (depth 1 instead of the default 10).
    let (durability, depth) = if qos.transient_local {
        ("1", "1")
    } else {
        ("", "")
    };
    format!(":{durability}:,{depth}:,:,:,,")
}

/// One ROS node's entities on `rmw_zenoh`: its token, and each publisher's key, token and GID.
#[derive(Debug, Clone)]
pub struct NodeEntities {
    domain: u32,
    session_id: String,
    node_id: u64,
    name: String,
    namespace: String,
    next_id: u64,
}

/// One publisher: where its samples go, its token, its GID and its next sequence number.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Publication {
    pub key: String,
    pub token: String,
    pub gid: [u8; 16],
    next_seq: i64,
}

impl NodeEntities {
    /// Node `name` in `namespace` (`/` for none) of the Zenoh session `session_id` (hex) in
    /// `domain`; the node is the session's first entity (id 0).
    ///
    /// # Errors
    ///
    /// A node name or namespace ROS would refuse.
    pub fn new(
        domain: u32,
        session_id: &str,
        name: &str,
        namespace: &str,
    ) -> Result<Self, Ros2Error> {
        check_name("node name", name, false)?;
        if name.contains('/') {
            return Err(Ros2Error::Live {
                reason: format!("node name {name:?} holds a /"),
            });
        }
        if namespace != "/" {
            check_name("namespace", namespace, true)?;
        }
        if session_id.is_empty() || !session_id.chars().all(|c| c.is_ascii_hexdigit()) {
            return Err(Ros2Error::Live {
                reason: format!("session id {session_id:?} is not hexadecimal"),
            });
        }
        Ok(Self {
            domain,
            session_id: session_id.to_string(),
            node_id: 0,
            name: name.to_string(),
            namespace: namespace.to_string(),
            next_id: 1,
        })
    }

    fn entity_prefix(&self, id: u64, kind: &str) -> String {
        format!(
            "{ADMIN_SPACE}/{}/{}/{}/{id}/{kind}/%/{}/{}",
            self.domain,
            self.session_id,
            self.node_id,
            mangle(&self.namespace),
            self.name
        )
    }

    /// The node's liveliness token.
    pub fn node_token(&self) -> String {
        self.entity_prefix(self.node_id, "NN")
    }

    /// A new publisher of `topic` with `type_name` and `qos` (the next entity id).
    ///
    /// # Errors
    ///
    /// As [`topic_key`].
    pub fn publisher(
        &mut self,
        topic: &str,
        type_name: &str,
        qos: QosProfile,
    ) -> Result<Publication, Ros2Error> {
        let key = topic_key(self.domain, topic, type_name)?;
        let id = self.next_id;
        self.next_id += 1;
        let token = format!(
            "{}/{}/{}/{}/{}",
            self.entity_prefix(id, "MP"),
            mangle(topic),
            dds_type_name(type_name)?,
            type_hash(type_name)?,
            qos_text(qos)
        );
        let digest = Sha256::digest(token.as_bytes());
        let mut gid = [0u8; 16];
        gid.copy_from_slice(&digest[..16]);
        Ok(Publication {
            key,
            token,
            gid,
            next_seq: 1,
        })
    }
}

/// One subscription: the key expression it listens on (any type hash: a camera driver built
/// against another revision of the message still reaches it) and its token.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Subscription {
    pub key: String,
    pub token: String,
    /// The topic's mangled name, as publishers' tokens carry it.
    pub mangled_topic: String,
}

impl NodeEntities {
    /// A new subscription of `topic` with `type_name` (the next entity id; `MS` token).
    ///
    /// # Errors
    ///
    /// As [`topic_key`].
    pub fn subscription(
        &mut self,
        topic: &str,
        type_name: &str,
        qos: QosProfile,
    ) -> Result<Subscription, Ros2Error> {
        check_name("topic", topic, true)?;
        let dds = dds_type_name(type_name)?;
        let id = self.next_id;
        self.next_id += 1;
        Ok(Subscription {
            key: format!("{}/{}/{dds}/*", self.domain, topic.trim_matches('/')),
            token: format!(
                "{}/{}/{dds}/{}/{}",
                self.entity_prefix(id, "MS"),
                mangle(topic),
                type_hash(type_name)?,
                qos_text(qos)
            ),
            mangled_topic: mangle(topic),
        })
    }
}

/// Whether liveliness token `token` is a publisher (`MP`) of the topic whose mangled name is
/// `mangled_topic` in `domain`: `@ros2_lv/<domain>/<zid>/<nid>/<eid>/MP/<enclave>/<ns>/<node>/
/// <topic>/…`.
pub fn is_publisher_of(token: &str, domain: u32, mangled_topic: &str) -> bool {
    let parts: Vec<&str> = token.split('/').collect();
    parts.len() >= 10
        && parts[0] == ADMIN_SPACE
        && parts[1] == domain.to_string()
        && parts[5] == "MP"
        && parts[9] == mangled_topic
}

impl Publication {
    /// The attachment of this publisher's next sample, sent at `source_timestamp_ns`.
    pub fn next_attachment(&mut self, source_timestamp_ns: i64) -> [u8; ATTACHMENT_LEN] {
        let seq = self.next_seq;
        self.next_seq += 1;
        attachment(seq, source_timestamp_ns, &self.gid)
    }
}

/// A sample's attachment (see the module docs).
pub fn attachment(
    sequence_number: i64,
    source_timestamp_ns: i64,
    gid: &[u8; 16],
) -> [u8; ATTACHMENT_LEN] {
    let mut out = [0u8; ATTACHMENT_LEN];
    out[..8].copy_from_slice(&sequence_number.to_le_bytes());
    out[8..16].copy_from_slice(&source_timestamp_ns.to_le_bytes());
    out[16] = 16;
    out[17..].copy_from_slice(gid);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_tokens_and_qos_follow_the_design_document() {
        assert_eq!(
            dds_type_name("sensor_msgs/msg/CompressedImage").unwrap(),
            "sensor_msgs::msg::dds_::CompressedImage_"
        );
        for bad in ["sensor_msgs/Image", "a/srv/B", "/msg/X", "a/msg/"] {
            assert!(dds_type_name(bad).is_err(), "{bad}");
        }
        let hash = type_hash("tf2_msgs/msg/TFMessage").unwrap();
        assert!(hash.starts_with("RIHS01_") && hash.len() == 7 + 64);
        assert_eq!(
            topic_key(7, "/tf", "tf2_msgs/msg/TFMessage").unwrap(),
            format!("7/tf/tf2_msgs::msg::dds_::TFMessage_/{hash}")
        );
        for bad in ["tf", "/", "//tf", "/O1//x", "/1abc", "/a-b", "/a*"] {
            assert!(
                topic_key(0, bad, "tf2_msgs/msg/TFMessage").is_err(),
                "{bad}"
            );
        }
        assert_eq!(qos_text(QosProfile::VOLATILE), "::,:,:,:,,");
        assert_eq!(qos_text(QosProfile::TRANSIENT_LOCAL), ":1:,1:,:,:,,");
        // Seven ':'-separated fields, the last three with their ','-separated parts.
        let volatile = qos_text(QosProfile::VOLATILE);
        let fields: Vec<&str> = volatile.split(':').collect();
        assert_eq!(fields.len(), 6);
        assert_eq!(
            fields
                .iter()
                .map(|f| f.split(',').count())
                .collect::<Vec<_>>(),
            [1, 1, 2, 2, 2, 3]
        );

        let mut node = NodeEntities::new(42, "a1b2c3", "waggle_recorder", "/").unwrap();
        assert_eq!(
            node.node_token(),
            "@ros2_lv/42/a1b2c3/0/0/NN/%/%/waggle_recorder"
        );
        let mut p = node
            .publisher(
                "/O1/events",
                "event_camera_msgs/msg/EventPacket",
                QosProfile::VOLATILE,
            )
            .unwrap();
        let ev = type_hash("event_camera_msgs/msg/EventPacket").unwrap();
        assert_eq!(
            p.key,
            format!("42/O1/events/event_camera_msgs::msg::dds_::EventPacket_/{ev}")
        );
        assert_eq!(
            p.token,
            format!(
                "@ros2_lv/42/a1b2c3/0/1/MP/%/%/waggle_recorder/%O1%events/\
                 event_camera_msgs::msg::dds_::EventPacket_/{ev}/::,:,:,:,,"
            )
        );
        let q = node
            .publisher(
                "/tf_static",
                "tf2_msgs/msg/TFMessage",
                QosProfile::TRANSIENT_LOCAL,
            )
            .unwrap();
        assert!(q.token.starts_with("@ros2_lv/42/a1b2c3/0/2/MP/"));
        assert!(q.token.ends_with("/:1:,1:,:,:,,"));
        assert_ne!(p.gid, q.gid);

        let a = p.next_attachment(1_700_000_000_123_456_789);
        let b = p.next_attachment(-5);
        assert_eq!(&a[..8], &1i64.to_le_bytes());
        assert_eq!(&a[8..16], &1_700_000_000_123_456_789i64.to_le_bytes());
        assert_eq!(a[16], 16);
        assert_eq!(&a[17..], &p.gid);
        assert_eq!(&b[..8], &2i64.to_le_bytes());
        assert_eq!(&b[8..16], &(-5i64).to_le_bytes());

        for (name, ns) in [("a/b", "/"), ("9x", "/"), ("x", "ns"), ("x", "/a b")] {
            assert!(NodeEntities::new(0, "ab", name, ns).is_err(), "{name} {ns}");
        }
        assert!(NodeEntities::new(0, "xyz", "n", "/").is_err());
        let s = node
            .subscription(
                "/camera/events",
                "event_camera_msgs/msg/EventPacket",
                QosProfile::VOLATILE,
            )
            .unwrap();
        assert_eq!(
            s.key,
            "42/camera/events/event_camera_msgs::msg::dds_::EventPacket_/*"
        );
        assert_eq!(
            s.token,
            format!(
                "@ros2_lv/42/a1b2c3/0/3/MS/%/%/waggle_recorder/%camera%events/\
                 event_camera_msgs::msg::dds_::EventPacket_/{ev}/::,:,:,:,,"
            )
        );
        assert!(is_publisher_of(
            &p.token.replace("%O1%events", "%camera%events"),
            42,
            &s.mangled_topic
        ));
        assert!(!is_publisher_of(&s.token, 42, &s.mangled_topic));
        assert!(!is_publisher_of(&p.token, 42, &s.mangled_topic));
        assert!(!is_publisher_of(&p.token, 7, "%O1%events"));
        assert!(is_publisher_of(&p.token, 42, "%O1%events"));
        let n = NodeEntities::new(3, "ff", "n", "/robot_1").unwrap();
        assert_eq!(n.node_token(), "@ros2_lv/3/ff/0/0/NN/%/%robot_1/n");
    }
}
