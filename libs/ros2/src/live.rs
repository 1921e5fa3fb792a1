//! The live ROS 2 view: a session's messages converted as the bag export converts them
//! ([`RosConverter`]) and published as `rmw_zenoh` publishes ([`crate::rmw_zenoh`]), so
//! `ros2 topic echo` under `RMW_IMPLEMENTATION=rmw_zenoh_cpp` sees them while the run flies.
//!
//! It is its own Zenoh session, apart from Waggle's authenticated bus: a client of the ROS
//! side's router (`rmw_zenohd`, `tcp/localhost:7447` by default), which forwards the samples
//! to the ROS nodes. The node (`waggle_recorder`) and each topic's publisher declare their
//! liveliness tokens, so the ROS graph lists them. A sample's source timestamp is the wall
//! clock at publication, as `rmw_zenoh` stamps it; it is output only. A sample that cannot be
//! converted or sent is counted, never fatal: the recording comes first.
//!
//! The same node can also listen ([`LiveView::subscribe`]): a camera driver's topic, received
//! as an `rmw_zenoh` subscription receives it (`waggle observe`), its publishers followed by
//! their liveliness tokens so the listener knows when the camera has gone.

use std::collections::{BTreeMap, BTreeSet};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use recording::Decoded;
use zenoh::Wait;
use zenoh::handlers::FifoChannelHandler;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::CongestionControl;
use zenoh::sample::{Sample, SampleKind};

use crate::bag::QosProfile;
use crate::convert::ExportOptions;
use crate::convert::RosConverter;
use crate::error::Ros2Error;
use crate::export::formation_pitches;
use crate::rmw_zenoh::{ADMIN_SPACE, NodeEntities, Publication, is_publisher_of};

/// The node name the view publishes as.
pub const NODE_NAME: &str = "waggle_recorder";
/// Where `rmw_zenohd` listens by default.
pub const DEFAULT_ROUTER: &str = "tcp/localhost:7447";

/// Where and how to publish.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LiveOptions {
    /// ROS domain id (`ROS_DOMAIN_ID`).
    pub domain: u32,
    /// The ROS side's Zenoh router endpoint.
    pub router: String,
    /// Observers of the session (their cameras' static transforms).
    pub observers: usize,
    /// The session's name, in errors.
    pub session: String,
}

/// What the view published.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LiveCounts {
    /// Samples published, per ROS topic.
    pub published: BTreeMap<String, u64>,
    /// Messages that did not convert, and samples Zenoh refused.
    pub failed: u64,
}

struct Topic {
    publication: Publication,
    publisher: Publisher<'static>,
    _token: LivelinessToken,
}

/// A running view.
pub struct LiveView {
    session: zenoh::Session,
    domain: u32,
    node: NodeEntities,
    _node_token: LivelinessToken,
    converter: RosConverter,
    topics: BTreeMap<String, Topic>,
    counts: LiveCounts,
}

fn live_err(what: &str, e: impl std::fmt::Display) -> Ros2Error {
    Ros2Error::Live {
        reason: format!("{what}: {e}"),
    }
}

impl LiveView {
    /// Connects to the ROS side's router and declares the node ([`NODE_NAME`]).
    ///
    /// # Errors
    ///
    /// A router that cannot be reached, or an endpoint Zenoh refuses.
    pub fn start(options: &LiveOptions) -> Result<Self, Ros2Error> {
        Self::start_node(options, NODE_NAME)
    }

    /// As [`LiveView::start`], for the node `node_name`.
    ///
    /// # Errors
    ///
    /// As [`LiveView::start`], and a node name ROS would refuse.
    pub fn start_node(options: &LiveOptions, node_name: &str) -> Result<Self, Ros2Error> {
        let mut config = zenoh::Config::default();
        let endpoint = serde_json_string(&options.router);
        for (key, value) in [
            ("mode", "\"client\"".to_string()),
            ("connect/endpoints", format!("[{endpoint}]")),
            ("scouting/multicast/enabled", "false".to_string()),
        ] {
            config
                .insert_json5(key, &value)
                .map_err(|e| live_err(&format!("configuring {key} = {value}"), e))?;
        }
        let session = zenoh::open(config).wait().map_err(|e| {
            live_err(
                &format!(
                    "reaching the ROS 2 router at {} (is rmw_zenohd running?)",
                    options.router
                ),
                e,
            )
        })?;
        let node = NodeEntities::new(options.domain, &session.zid().to_string(), node_name, "/")?;
        let node_token = session
            .liveliness()
            .declare_token(node.node_token())
            .wait()
            .map_err(|e| live_err("declaring the node's liveliness token", e))?;
        Ok(Self {
            session,
            domain: options.domain,
            node,
            _node_token: node_token,
            converter: RosConverter::new(
                &format!("session {}", options.session),
                ExportOptions::default(),
                formation_pitches(options.observers),
            ),
            topics: BTreeMap::new(),
            counts: LiveCounts::default(),
        })
    }

    /// Converts a recorded message of recording topic `topic` and publishes what it gives.
    pub fn publish(&mut self, topic: &str, msg: Decoded, log_time_ns: u64) {
        if let Err(e) = self.converter.convert(topic, msg, log_time_ns) {
            self.counts.failed += 1;
            if self.counts.failed <= 5 {
                eprintln!("ROS 2 view: {e}");
            }
        }
        for m in self.converter.take() {
            if let Err(e) = self.put(&m.topic, m.type_name, m.qos, m.cdr) {
                self.counts.failed += 1;
                if self.counts.failed <= 5 {
                    eprintln!("ROS 2 view: {e}");
                }
            }
        }
    }

    fn put(
        &mut self,
        topic: &str,
        type_name: &str,
        qos: QosProfile,
        cdr: Vec<u8>,
    ) -> Result<(), Ros2Error> {
        if !self.topics.contains_key(topic) {
            let publication = self.node.publisher(topic, type_name, qos)?;
            let publisher = self
                .session
                .declare_publisher(publication.key.clone())
                .congestion_control(CongestionControl::Block)
                .wait()
                .map_err(|e| live_err(&format!("declaring the publisher of {topic}"), e))?;
            let token = self
                .session
                .liveliness()
                .declare_token(publication.token.clone())
                .wait()
                .map_err(|e| live_err(&format!("declaring the token of {topic}"), e))?;
            self.topics.insert(
                topic.to_string(),
                Topic {
                    publication,
                    publisher,
                    _token: token,
                },
            );
        }
        let t = self.topics.get_mut(topic).expect("inserted above");
        let now_ns = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX));
        let attachment = t.publication.next_attachment(now_ns);
        t.publisher
            .put(cdr)
            .attachment(attachment.to_vec())
            .wait()
            .map_err(|e| live_err(&format!("publishing on {topic}"), e))?;
        *self.counts.published.entry(topic.to_string()).or_insert(0) += 1;
        Ok(())
    }

    /// Subscribes to `topic` of `type_name` as an `rmw_zenoh` subscription does: its data key
    /// (any type hash), its `MS` liveliness token, and a watch on the topic's publishers' tokens.
    ///
    /// # Errors
    ///
    /// A topic or type [`NodeEntities::subscription`] refuses, or Zenoh refusing a declaration.
    pub fn subscribe(
        &mut self,
        topic: &str,
        type_name: &str,
    ) -> Result<LiveSubscription, Ros2Error> {
        let sub = self
            .node
            .subscription(topic, type_name, QosProfile::VOLATILE)?;
        let data = self
            .session
            .declare_subscriber(sub.key.clone())
            .wait()
            .map_err(|e| live_err(&format!("subscribing to {topic}"), e))?;
        let publishers = self
            .session
            .liveliness()
            .declare_subscriber(format!("{ADMIN_SPACE}/{}/**", self.domain))
            .history(true)
            .wait()
            .map_err(|e| live_err(&format!("watching the publishers of {topic}"), e))?;
        // Declared after the subscriber, so a publisher that waits for this token before
        // publishing finds the subscriber in place.
        let token = self
            .session
            .liveliness()
            .declare_token(sub.token.clone())
            .wait()
            .map_err(|e| live_err(&format!("declaring the token of {topic}"), e))?;
        Ok(LiveSubscription {
            domain: self.domain,
            topic: topic.to_string(),
            mangled_topic: sub.mangled_topic,
            data,
            publishers,
            _token: token,
            alive: BTreeSet::new(),
            seen: 0,
        })
    }

    /// What was published so far.
    pub fn counts(&self) -> &LiveCounts {
        &self.counts
    }

    /// Undeclares every token and closes the session.
    ///
    /// # Errors
    ///
    /// When Zenoh fails to close the session.
    pub fn close(self) -> Result<LiveCounts, Ros2Error> {
        let Self {
            session,
            topics,
            _node_token,
            counts,
            ..
        } = self;
        for (_, t) in topics {
            let _ = t._token.undeclare().wait();
            let _ = t.publisher.undeclare().wait();
        }
        let _ = _node_token.undeclare().wait();
        session
            .close()
            .wait()
            .map_err(|e| live_err("closing the session", e))?;
        Ok(counts)
    }
}

/// `s` as a JSON string literal (an endpoint inside the JSON5 config).
fn serde_json_string(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if c.is_control() => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// A topic subscribed to ([`LiveView::subscribe`]): its samples in arrival order, and whether
/// the publishers that appeared on it have all left.
pub struct LiveSubscription {
    domain: u32,
    topic: String,
    mangled_topic: String,
    data: Subscriber<FifoChannelHandler<Sample>>,
    publishers: Subscriber<FifoChannelHandler<Sample>>,
    _token: LivelinessToken,
    /// The topic's publishers' tokens now declared.
    alive: BTreeSet<String>,
    /// Publishers seen since the subscription began.
    seen: u64,
}

/// What [`LiveSubscription::next`] found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LiveInput {
    /// A sample's payload (the message's CDR bytes).
    Message(Vec<u8>),
    /// Nothing arrived before the deadline.
    Idle,
    /// Every publisher seen on the topic has withdrawn its token, and every sample that came
    /// before the withdrawal has been handed out.
    PublishersGone,
}

impl LiveSubscription {
    /// The topic.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// Publishers of the topic seen so far.
    pub fn publishers_seen(&self) -> u64 {
        self.seen
    }

    fn watch_publishers(&mut self) {
        while let Ok(Some(sample)) = self.publishers.try_recv() {
            let token = sample.key_expr().as_str();
            if !is_publisher_of(token, self.domain, &self.mangled_topic) {
                continue;
            }
            match sample.kind() {
                SampleKind::Put => {
                    if self.alive.insert(token.to_string()) {
                        self.seen += 1;
                    }
                }
                SampleKind::Delete => {
                    self.alive.remove(token);
                }
            }
        }
    }

    /// The next sample, waiting up to `timeout`. A publisher's samples travel before its
    /// token's withdrawal, so the data queue is drained before [`LiveInput::PublishersGone`].
    pub fn next(&mut self, timeout: Duration) -> LiveInput {
        let deadline = Instant::now() + timeout;
        loop {
            if let Ok(Some(sample)) = self.data.try_recv() {
                return LiveInput::Message(sample.payload().to_bytes().into_owned());
            }
            self.watch_publishers();
            if self.seen > 0 && self.alive.is_empty() {
                return match self.data.try_recv() {
                    Ok(Some(sample)) => {
                        LiveInput::Message(sample.payload().to_bytes().into_owned())
                    }
                    _ => LiveInput::PublishersGone,
                };
            }
            let now = Instant::now();
            if now >= deadline {
                return LiveInput::Idle;
            }
            // Short waits on the data queue, so a withdrawn token is noticed within 20 ms.
            let wait = (deadline - now).min(Duration::from_millis(20));
            if let Ok(Some(sample)) = self.data.recv_timeout(wait) {
                return LiveInput::Message(sample.payload().to_bytes().into_owned());
            }
        }
    }
}
