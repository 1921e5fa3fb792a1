//! One Zenoh session with a single ordered inbox.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use proto::{Keys, Validate};
use serde::Serialize;
use serde::de::DeserializeOwned;
use zenoh::Wait;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::CongestionControl;
use zenoh::sample::{Sample, SampleKind};

use crate::delay::Delayer;
use crate::endpoints::{Endpoints, config};
use crate::error::BusError;

fn zenoh_err(what: impl Into<String>, e: impl std::fmt::Display) -> BusError {
    BusError::Zenoh {
        what: what.into(),
        message: e.to_string(),
    }
}

/// Something that reached this process.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Inbound {
    /// A message published on `key`.
    Data { key: String, payload: Vec<u8> },
    /// A liveliness token appeared (`alive = true`) or disappeared.
    Liveliness { key: String, alive: bool },
}

/// What [`Bus::close`] waits on a `quic/` session before closing it. Zenoh 1.10.2 closes a QUIC
/// connection at once, discarding what is still queued to leave (a camera's final report went
/// missing from a run's summary); a TCP link lingers by itself. Nothing is decided by it: the
/// last messages of a process are its reports, which the lockstep never waits on.
const QUIC_CLOSE_LINGER: Duration = Duration::from_millis(500);

/// True when the configuration dials or listens on a `quic/` endpoint.
fn uses_quic(config: &zenoh::Config) -> bool {
    ["connect/endpoints", "listen/endpoints"]
        .iter()
        .any(|k| config.get_json(k).is_ok_and(|v| v.contains("quic/")))
}

/// A Zenoh session of one Waggle process.
///
/// Publications use reliable, blocking congestion control: a lockstep message is never
/// dropped, a slow subscriber slows its publisher down instead.
pub struct Bus {
    keys: Keys,
    // Declared entities must be dropped before the session; field order is drop order.
    publishers: BTreeMap<String, Publisher<'static>>,
    /// The test shim holding back chosen keys ([`crate::delay`]); `None` in real runs.
    delayer: Option<Delayer>,
    /// How long [`Bus::close`] waits before closing, for what is still queued to leave.
    close_linger: Duration,
    subscribers: Vec<Subscriber<()>>,
    tokens: BTreeMap<String, LivelinessToken>,
    session: zenoh::Session,
    tx: mpsc::Sender<Inbound>,
    rx: mpsc::Receiver<Inbound>,
    pending: VecDeque<Inbound>,
    alive: BTreeSet<String>,
}

impl Bus {
    /// Opens a session for Waggle session id `session` with the given endpoints.
    pub fn open(session: &str, endpoints: &Endpoints) -> Result<Self, BusError> {
        Self::open_with_acl(session, endpoints, &[])
    }

    /// Opens a session whose links deny the key expressions in `deny` (see [`config`]).
    pub fn open_with_acl(
        session: &str,
        endpoints: &Endpoints,
        deny: &[String],
    ) -> Result<Self, BusError> {
        Self::open_config(session, config(endpoints, deny)?)
    }

    /// Opens a session for Waggle session id `session` with a ready Zenoh configuration (the
    /// launcher's router, see [`crate::router_config`]).
    pub fn open_config(session: &str, config: zenoh::Config) -> Result<Self, BusError> {
        let keys = Keys::new(session)?;
        let close_linger = if uses_quic(&config) {
            QUIC_CLOSE_LINGER
        } else {
            Duration::ZERO
        };
        let zenoh_session = zenoh::open(config)
            .wait()
            .map_err(|e| zenoh_err("opening the session", e))?;
        let (tx, rx) = mpsc::channel();
        let delayer = Delayer::from_env(keys.prefix(), &zenoh_session)?;
        Ok(Self {
            keys,
            publishers: BTreeMap::new(),
            delayer,
            close_linger,
            subscribers: Vec::new(),
            tokens: BTreeMap::new(),
            session: zenoh_session,
            tx,
            rx,
            pending: VecDeque::new(),
            alive: BTreeSet::new(),
        })
    }

    /// Key builder of this session.
    pub fn keys(&self) -> &Keys {
        &self.keys
    }

    /// Subscribes to `key` (a key expression); its messages arrive through [`Bus::recv`].
    pub fn subscribe(&mut self, key: &str) -> Result<(), BusError> {
        let tx = self.tx.clone();
        let sub = self
            .session
            .declare_subscriber(key.to_string())
            .callback(move |sample: Sample| {
                let _ = tx.send(Inbound::Data {
                    key: sample.key_expr().as_str().to_string(),
                    payload: sample.payload().to_bytes().into_owned(),
                });
            })
            .wait()
            .map_err(|e| zenoh_err(format!("subscribing to {key}"), e))?;
        self.subscribers.push(sub);
        Ok(())
    }

    /// Watches the liveliness tokens matching `key`, including those already present.
    pub fn watch_liveliness(&mut self, key: &str) -> Result<(), BusError> {
        let tx = self.tx.clone();
        let sub = self
            .session
            .liveliness()
            .declare_subscriber(key.to_string())
            .history(true)
            .callback(move |sample: Sample| {
                let _ = tx.send(Inbound::Liveliness {
                    key: sample.key_expr().as_str().to_string(),
                    alive: sample.kind() == SampleKind::Put,
                });
            })
            .wait()
            .map_err(|e| zenoh_err(format!("watching liveliness of {key}"), e))?;
        self.subscribers.push(sub);
        Ok(())
    }

    /// Declares the liveliness token `key` (kept until the process exits or it is undeclared).
    pub fn declare_token(&mut self, key: &str) -> Result<(), BusError> {
        let token = self
            .session
            .liveliness()
            .declare_token(key.to_string())
            .wait()
            .map_err(|e| zenoh_err(format!("declaring token {key}"), e))?;
        self.tokens.insert(key.to_string(), token);
        Ok(())
    }

    /// Encodes `msg` with [`proto::encode`] and publishes it on `key`.
    pub fn put<T: Serialize>(&mut self, key: &str, msg: &T) -> Result<(), BusError> {
        self.put_bytes(key, proto::encode(msg))
    }

    /// Publishes raw bytes on `key` (reliable, blocking congestion control).
    pub fn put_bytes(&mut self, key: &str, bytes: Vec<u8>) -> Result<(), BusError> {
        let bytes = match &self.delayer {
            Some(d) => match d.hold(key, bytes) {
                Some(bytes) => bytes,
                None => return Ok(()),
            },
            None => bytes,
        };
        if !self.publishers.contains_key(key) {
            let publisher = self
                .session
                .declare_publisher(key.to_string())
                .congestion_control(CongestionControl::Block)
                .wait()
                .map_err(|e| zenoh_err(format!("declaring publisher {key}"), e))?;
            self.publishers.insert(key.to_string(), publisher);
        }
        self.publishers[key]
            .put(bytes)
            .wait()
            .map_err(|e| zenoh_err(format!("publishing on {key}"), e))
    }

    /// True when some other process has a subscriber matching `key` (Zenoh's matching status
    /// of a publisher on `key`). Used to prove which keys a process does — and does not —
    /// subscribe to.
    pub fn has_subscribers(&mut self, key: &str) -> Result<bool, BusError> {
        let publisher = self
            .session
            .declare_publisher(key.to_string())
            .wait()
            .map_err(|e| zenoh_err(format!("declaring publisher {key}"), e))?;
        let status = publisher
            .matching_status()
            .wait()
            .map_err(|e| zenoh_err(format!("matching status of {key}"), e))?;
        Ok(status.matching())
    }

    /// The next inbound item, waiting at most `timeout`; `None` when nothing arrived.
    pub fn recv(&mut self, timeout: Duration) -> Option<Inbound> {
        if let Some(item) = self.pending.pop_front() {
            return Some(item);
        }
        let item = self.rx.recv_timeout(timeout).ok()?;
        self.note(&item);
        Some(item)
    }

    /// Like [`Bus::recv`] but without waiting.
    pub fn try_recv(&mut self) -> Option<Inbound> {
        if let Some(item) = self.pending.pop_front() {
            return Some(item);
        }
        let item = self.rx.try_recv().ok()?;
        self.note(&item);
        Some(item)
    }

    /// Liveliness is tracked when an item leaves the channel, so [`Bus::is_alive`] is current
    /// even for items still buffered by [`Bus::wait_for`].
    fn note(&mut self, item: &Inbound) {
        if let Inbound::Liveliness { key, alive } = item {
            if *alive {
                self.alive.insert(key.clone());
            } else {
                self.alive.remove(key);
            }
        }
    }

    /// True while the liveliness token `key` is present (among the watched ones).
    pub fn is_alive(&self, key: &str) -> bool {
        self.alive.contains(key)
    }

    /// Every watched liveliness token currently present.
    pub fn alive_keys(&self) -> &BTreeSet<String> {
        &self.alive
    }

    /// Waits until `done` holds for the present liveliness tokens, buffering everything else
    /// that arrives meanwhile (later [`Bus::recv`] calls return it in order).
    pub fn wait_for(
        &mut self,
        what: &str,
        timeout: Duration,
        done: impl Fn(&BTreeSet<String>) -> bool,
    ) -> Result<(), BusError> {
        let start = Instant::now();
        loop {
            if done(&self.alive) {
                return Ok(());
            }
            let left = timeout.saturating_sub(start.elapsed());
            if left.is_zero() {
                return Err(BusError::Timeout {
                    what: what.to_string(),
                    waited_s: start.elapsed().as_secs_f64(),
                });
            }
            if let Ok(item) = self.rx.recv_timeout(left.min(Duration::from_millis(100))) {
                self.note(&item);
                self.pending.push_back(item);
            }
        }
    }

    /// Closes the session now, so peers see this process's tokens disappear at once.
    pub fn close(mut self) -> Result<(), BusError> {
        // What the test shim holds back leaves before this process's tokens disappear.
        if let Some(d) = self.delayer.as_mut() {
            d.flush();
        }
        std::thread::sleep(self.close_linger);
        self.tokens.clear();
        self.subscribers.clear();
        self.publishers.clear();
        self.session
            .close()
            .wait()
            .map_err(|e| zenoh_err("closing the session", e))
    }
}

/// Decodes a message received on `key` with [`proto::decode`].
pub fn decode<T: DeserializeOwned + Validate>(key: &str, payload: &[u8]) -> Result<T, BusError> {
    proto::decode(payload).map_err(|source| BusError::Decode {
        key: key.to_string(),
        source,
    })
}
