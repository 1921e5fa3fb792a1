//! The live view: a Foxglove WebSocket server (the `foxglove` crate's) carrying every view
//! channel the recorder writes — the same messages, as they are recorded — so a run can be
//! watched in Foxglove while it flies.

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::sync::Arc;

use anyhow::{Context as _, Result, bail};
use foxglove::{ChannelBuilder, Context, PartialMetadata, RawChannel, WebSocketServer};
use recording::ViewTap;
use recording::foxglove::{VIEW_ENCODING, ViewKind, ViewMessage};

/// The server and one channel per view topic.
///
/// The channels the session is known to carry are created before the server starts, so every
/// client learns of them while it registers. A channel created while a client is connected is
/// advertised to it before the `foxglove` crate (0.30.3) registers the channel for that client:
/// a client that subscribes at once can get "Unknown channel ID" and never receive it. We saw
/// one camera's images missing for a whole run that way on a loaded 2-core machine. A topic
/// outside the expected set is still served, created when its first message comes.
pub struct Live {
    context: Arc<Context>,
    channels: BTreeMap<String, Arc<RawChannel>>,
    /// Kept so the server lives as long as the recorder.
    _server: foxglove::WebSocketServerHandle,
}

impl Live {
    /// Serves on `addr`. Only loopback: the view shows ground truth and the server has no
    /// authentication (watch a remote host through an SSH tunnel).
    pub fn start(addr: SocketAddr, session: &str, expected: &[(String, ViewKind)]) -> Result<Self> {
        if !addr.ip().is_loopback() {
            bail!(
                "--live {addr}: the live view serves ground truth without authentication, so \
                 it listens on loopback only (watch another host through `ssh -L`)"
            );
        }
        let context = Context::new();
        let mut channels = BTreeMap::new();
        for (topic, kind) in expected {
            let channel = channel(&context, topic, kind.schema())
                .with_context(|| format!("creating the live channel {topic}"))?;
            channels.insert(topic.clone(), channel);
        }
        let server = WebSocketServer::new()
            .name(format!("waggle {session}"))
            .bind(addr.ip().to_string(), addr.port())
            .context(&context)
            .start_blocking()
            .with_context(|| format!("starting the live view on {addr}"))?;
        tracing::info!(
            port = server.port(),
            "live view (Foxglove WebSocket) serving"
        );
        Ok(Self {
            context,
            channels,
            _server: server,
        })
    }
}

impl ViewTap for Live {
    fn view(&mut self, topic: &str, log_time_ns: u64, msg: &ViewMessage) {
        let channel = match self.channels.get(topic) {
            Some(c) => c.clone(),
            None => {
                match channel(&self.context, topic, msg.schema.clone()) {
                    Ok(c) => {
                        self.channels.insert(topic.to_string(), c.clone());
                        c
                    }
                    Err(e) => {
                        // The recording goes on whatever happens to the view.
                        tracing::warn!(topic, %e, "live view: channel not created");
                        return;
                    }
                }
            }
        };
        channel.log_with_meta(
            &msg.data,
            PartialMetadata {
                log_time: Some(log_time_ns),
            },
        );
    }
}

fn channel(
    context: &Arc<Context>,
    topic: &str,
    schema: foxglove::Schema,
) -> Result<Arc<RawChannel>, foxglove::FoxgloveError> {
    ChannelBuilder::new(topic)
        .context(context)
        .message_encoding(VIEW_ENCODING)
        .schema(schema)
        .build_raw()
}
