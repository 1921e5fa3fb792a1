//! The bag writer: one MCAP file as rosbag2's MCAP storage plugin writes it, and the bag's
//! `metadata.yaml` as rosbag2 (Jazzy, metadata version 9) writes it.
//!
//! MCAP: profile `ros2`; one schema per type (`ros2msg`, [`definitions::full_text`]), one channel
//! per topic (`cdr`, metadata `offered_qos_profiles` — the profiles as a YAML string, version 9
//! spelling — and `topic_type_hash`), message sequence 0 as rosbag2 writes it, publish time =
//! log time, and at the end a metadata record `rosbag2` whose `serialized_metadata` is the bag
//! metadata in YAML. Chunks are zstd-compressed (as rosbag2's `zstd_fast` preset does; its
//! default is uncompressed), single-threaded so the bytes never depend on the machine.
//!
//! `metadata.yaml` is yaml-cpp's block layout of rosbag2's `BagMetadata` (two-space indent,
//! sequences indented under their key, `""` for empty strings, `~` for the empty `custom_data`,
//! no newline at the end). rosbag2 lists topics in its hash map's order; here they are sorted by
//! name.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use mcap::records::Metadata;
use mcap::{Compression, WriteOptions, Writer};

use crate::cdr::RosMessage;
use crate::definitions;
use crate::error::Ros2Error;

/// rosbag2's metadata version in Jazzy.
pub const METADATA_VERSION: u32 = 9;
/// rmw's "infinite" duration (`RMW_DURATION_INFINITE`), as rosbag2 writes it: seconds, ns.
const INFINITE_DURATION: (u64, u64) = (9_223_372_036, 854_775_807);
/// mcap's C++ writer's default chunk size, which rosbag2 keeps.
const CHUNK_BYTES: u64 = 768 * 1024;

/// The QoS a topic's publisher offered, as rosbag2 records it from the graph: history and depth
/// are not visible there (`unknown`, 0), deadline, lifespan and lease are infinite, liveliness
/// automatic, reliability reliable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct QosProfile {
    /// `transient_local` (latched, e.g. `/tf_static`) rather than `volatile`.
    pub transient_local: bool,
}

impl QosProfile {
    pub const VOLATILE: Self = Self {
        transient_local: false,
    };
    pub const TRANSIENT_LOCAL: Self = Self {
        transient_local: true,
    };

    /// One item of a YAML block sequence, each line after the first indented by `indent`.
    fn yaml_item(&self, indent: &str) -> String {
        let (sec, nsec) = INFINITE_DURATION;
        let duration = |name: &str| {
            format!("{indent}  {name}:\n{indent}    sec: {sec}\n{indent}    nsec: {nsec}\n")
        };
        format!(
            "- history: unknown\n{indent}  depth: 0\n{indent}  reliability: reliable\n\
             {indent}  durability: {}\n{}{}{indent}  liveliness: automatic\n{}\
             {indent}  avoid_ros_namespace_conventions: false",
            if self.transient_local {
                "transient_local"
            } else {
                "volatile"
            },
            duration("deadline"),
            duration("lifespan"),
            duration("liveliness_lease_duration"),
        )
    }

    /// The channel metadata `offered_qos_profiles`: `YAML::Dump` of the one-profile list.
    pub fn channel_metadata(&self) -> String {
        self.yaml_item("")
    }
}

/// A topic of the bag.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicSpec {
    pub name: String,
    pub type_name: String,
    pub qos: QosProfile,
    /// RIHS01 hash of the type.
    pub type_hash: String,
    pub message_count: u64,
}

/// What a finished bag holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BagSummary {
    pub dir: PathBuf,
    /// The MCAP file's name inside `dir`.
    pub file_name: String,
    pub file_bytes: u64,
    /// First message's log time, ns (0 without messages).
    pub starting_time_ns: u64,
    pub duration_ns: u64,
    pub message_count: u64,
    /// Sorted by name.
    pub topics: Vec<TopicSpec>,
}

/// A plain YAML scalar if yaml-cpp would write it plain, else double-quoted.
fn yaml_string(s: &str) -> String {
    let plain = !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '/' | '.' | '-'))
        && !s.starts_with('-')
        && !matches!(
            s.to_ascii_lowercase().as_str(),
            "true" | "false" | "yes" | "no" | "on" | "off" | "null" | "y" | "n"
        );
    if plain {
        s.to_string()
    } else {
        format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""))
    }
}

impl BagSummary {
    /// rosbag2's `BagMetadata` in YAML (what `YAML::Dump` writes, no final newline), each line
    /// after the first indented by `indent`.
    fn metadata_yaml(&self, indent: &str) -> String {
        let i = indent;
        let mut y = format!(
            "version: {METADATA_VERSION}\n{i}storage_identifier: mcap\n\
             {i}duration:\n{i}  nanoseconds: {}\n\
             {i}starting_time:\n{i}  nanoseconds_since_epoch: {}\n\
             {i}message_count: {}\n{i}topics_with_message_count:\n",
            self.duration_ns, self.starting_time_ns, self.message_count
        );
        for t in &self.topics {
            let qos = t.qos.yaml_item(&format!("{i}        "));
            y += &format!(
                "{i}  - topic_metadata:\n{i}      name: {}\n{i}      type: {}\n\
                 {i}      serialization_format: cdr\n{i}      offered_qos_profiles:\n\
                 {i}        {qos}\n{i}      type_description_hash: {}\n\
                 {i}    message_count: {}\n",
                yaml_string(&t.name),
                yaml_string(&t.type_name),
                yaml_string(&t.type_hash),
                t.message_count
            );
        }
        let file = yaml_string(&self.file_name);
        y += &format!(
            "{i}compression_format: \"\"\n{i}compression_mode: \"\"\n\
             {i}relative_file_paths:\n{i}  - {file}\n{i}files:\n{i}  - path: {file}\n\
             {i}    starting_time:\n{i}      nanoseconds_since_epoch: {}\n\
             {i}    duration:\n{i}      nanoseconds: {}\n{i}    message_count: {}\n\
             {i}custom_data: ~\n{i}ros_distro: {}",
            self.starting_time_ns,
            self.duration_ns,
            self.message_count,
            crate::ROS_DISTRO
        );
        y
    }

    /// The bag's `metadata.yaml`, byte for byte as rosbag2 writes it.
    pub fn metadata_file(&self) -> String {
        format!(
            "rosbag2_bagfile_information:\n  {}",
            self.metadata_yaml("  ")
        )
    }
}

struct Topic {
    channel: u16,
    spec: TopicSpec,
}

/// Writes one bag directory: `<dir>/<dir name>_0.mcap` and `<dir>/metadata.yaml`.
pub struct BagWriter {
    dir: PathBuf,
    file_name: String,
    mcap: Writer<BufWriter<File>>,
    schemas: BTreeMap<String, u16>,
    topics: BTreeMap<String, Topic>,
    first_ns: Option<u64>,
    last_ns: u64,
    count: u64,
}

impl BagWriter {
    /// Creates `dir` (which must not exist, or be empty) and the bag's MCAP file in it.
    pub fn create(dir: &Path) -> Result<Self, Ros2Error> {
        let shown = dir.display().to_string();
        let io = |source| Ros2Error::Io {
            path: shown.clone(),
            source,
        };
        if dir.exists() {
            let empty = dir.is_dir() && std::fs::read_dir(dir).map_err(io)?.next().is_none();
            if !empty {
                return Err(Ros2Error::OutputExists { path: shown });
            }
        }
        std::fs::create_dir_all(dir).map_err(io)?;
        let name = dir
            .file_name()
            .map_or_else(|| "bag".to_string(), |n| n.to_string_lossy().into_owned());
        let file_name = format!("{name}_0.mcap");
        let path = dir.join(&file_name);
        let file = File::create(&path).map_err(|source| Ros2Error::Io {
            path: path.display().to_string(),
            source,
        })?;
        let mcap = WriteOptions::new()
            .profile("ros2")
            .library(concat!("waggle ros2-bag ", env!("CARGO_PKG_VERSION")))
            .compression(Some(Compression::Zstd))
            .compression_threads(0)
            .chunk_size(Some(CHUNK_BYTES))
            .create(BufWriter::new(file))
            .map_err(|source| Ros2Error::Mcap {
                path: path.display().to_string(),
                source,
            })?;
        Ok(Self {
            dir: dir.to_path_buf(),
            file_name,
            mcap,
            schemas: BTreeMap::new(),
            topics: BTreeMap::new(),
            first_ns: None,
            last_ns: 0,
            count: 0,
        })
    }

    fn mcap_error(&self, source: mcap::McapError) -> Ros2Error {
        Ros2Error::Mcap {
            path: self.dir.join(&self.file_name).display().to_string(),
            source,
        }
    }

    /// Whether `topic` was added.
    pub fn has_topic(&self, topic: &str) -> bool {
        self.topics.contains_key(topic)
    }

    /// Declares `topic` of type `type_name` (`pkg/msg/Type`): its schema (once per type) and
    /// its channel. Adding a topic twice changes nothing.
    pub fn add_topic(
        &mut self,
        topic: &str,
        type_name: &str,
        qos: QosProfile,
    ) -> Result<(), Ros2Error> {
        if self.has_topic(topic) {
            return Ok(());
        }
        let schema = match self.schemas.get(type_name) {
            Some(&id) => id,
            None => {
                let text = definitions::full_text(type_name)?;
                let id = self
                    .mcap
                    .add_schema(type_name, "ros2msg", text.as_bytes())
                    .map_err(|e| self.mcap_error(e))?;
                self.schemas.insert(type_name.to_string(), id);
                id
            }
        };
        let type_hash = definitions::type_hash(type_name)?;
        let metadata = BTreeMap::from([
            ("offered_qos_profiles".to_string(), qos.channel_metadata()),
            ("topic_type_hash".to_string(), type_hash.clone()),
        ]);
        let channel = self
            .mcap
            .add_channel(schema, topic, "cdr", &metadata)
            .map_err(|e| self.mcap_error(e))?;
        let spec = TopicSpec {
            name: topic.to_string(),
            type_name: type_name.to_string(),
            qos,
            type_hash,
            message_count: 0,
        };
        self.topics
            .insert(topic.to_string(), Topic { channel, spec });
        Ok(())
    }

    /// Writes one serialized message (CDR, header included) on `topic` at `log_time_ns`.
    pub fn write_cdr(
        &mut self,
        topic: &str,
        log_time_ns: u64,
        cdr: &[u8],
    ) -> Result<(), Ros2Error> {
        let Some(t) = self.topics.get_mut(topic) else {
            return Err(Ros2Error::UnknownTopic {
                topic: topic.to_string(),
            });
        };
        t.spec.message_count += 1;
        let channel_id = t.channel;
        self.mcap
            .write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id,
                    sequence: 0,
                    log_time: log_time_ns,
                    publish_time: log_time_ns,
                },
                cdr,
            )
            .map_err(|e| self.mcap_error(e))?;
        self.first_ns = Some(self.first_ns.map_or(log_time_ns, |f| f.min(log_time_ns)));
        self.last_ns = self.last_ns.max(log_time_ns);
        self.count += 1;
        Ok(())
    }

    /// Declares `topic` for `M` if needed and writes `msg` on it.
    pub fn write<M: RosMessage>(
        &mut self,
        topic: &str,
        qos: QosProfile,
        log_time_ns: u64,
        msg: &M,
    ) -> Result<(), Ros2Error> {
        self.add_topic(topic, M::TYPE_NAME, qos)?;
        self.write_cdr(topic, log_time_ns, &msg.to_cdr())
    }

    /// Writes the `rosbag2` metadata record, closes the MCAP file and writes `metadata.yaml`.
    pub fn finish(mut self) -> Result<BagSummary, Ros2Error> {
        let starting_time_ns = self.first_ns.unwrap_or(0);
        let mut summary = BagSummary {
            dir: self.dir.clone(),
            file_name: self.file_name.clone(),
            file_bytes: 0,
            starting_time_ns,
            duration_ns: self.last_ns.saturating_sub(starting_time_ns),
            message_count: self.count,
            topics: self.topics.values().map(|t| t.spec.clone()).collect(),
        };
        let record = Metadata {
            name: "rosbag2".into(),
            metadata: BTreeMap::from([(
                "serialized_metadata".to_string(),
                summary.metadata_yaml(""),
            )]),
        };
        self.mcap
            .write_metadata(&record)
            .map_err(|e| self.mcap_error(e))?;
        self.mcap.finish().map_err(|e| self.mcap_error(e))?;
        let path = self.dir.join(&self.file_name);
        let io = |source| Ros2Error::Io {
            path: path.display().to_string(),
            source,
        };
        let mut inner = self.mcap.into_inner();
        std::io::Write::flush(&mut inner).map_err(io)?;
        drop(inner);
        summary.file_bytes = std::fs::metadata(&path).map_err(io)?.len();
        let yaml = self.dir.join("metadata.yaml");
        std::fs::write(&yaml, summary.metadata_file()).map_err(|source| Ros2Error::Io {
            path: yaml.display().to_string(),
            source,
        })?;
        Ok(summary)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metadata_yaml_is_rosbag2s_layout() {
        let s = BagSummary {
            dir: PathBuf::from("b"),
            file_name: "b_0.mcap".into(),
            file_bytes: 0,
            starting_time_ns: 40_000_000,
            duration_ns: 5,
            message_count: 3,
            topics: vec![TopicSpec {
                name: "/tf_static".into(),
                type_name: "tf2_msgs/msg/TFMessage".into(),
                qos: QosProfile::TRANSIENT_LOCAL,
                type_hash: "RIHS01_ab".into(),
                message_count: 3,
            }],
        };
        let want = "rosbag2_bagfile_information:
  version: 9
  storage_identifier: mcap
  duration:
    nanoseconds: 5
  starting_time:
    nanoseconds_since_epoch: 40000000
  message_count: 3
  topics_with_message_count:
    - topic_metadata:
        name: /tf_static
        type: tf2_msgs/msg/TFMessage
        serialization_format: cdr
        offered_qos_profiles:
          - history: unknown
            depth: 0
            reliability: reliable
            durability: transient_local
            deadline:
              sec: 9223372036
              nsec: 854775807
            lifespan:
              sec: 9223372036
              nsec: 854775807
            liveliness: automatic
            liveliness_lease_duration:
              sec: 9223372036
              nsec: 854775807
            avoid_ros_namespace_conventions: false
        type_description_hash: RIHS01_ab
      message_count: 3
  compression_format: \"\"
  compression_mode: \"\"
  relative_file_paths:
    - b_0.mcap
  files:
    - path: b_0.mcap
      starting_time:
        nanoseconds_since_epoch: 40000000
      duration:
        nanoseconds: 5
      message_count: 3
  custom_data: ~
  ros_distro: jazzy";
        assert_eq!(s.metadata_file(), want);
        assert!(QosProfile::VOLATILE
            .channel_metadata()
            .starts_with("- history: unknown\n  depth: 0\n  reliability: reliable\n  durability: volatile\n  deadline:\n    sec: 9223372036\n"));
        assert_eq!(yaml_string("my bag"), "\"my bag\"");
        assert_eq!(yaml_string("on"), "\"on\"");
    }
}
