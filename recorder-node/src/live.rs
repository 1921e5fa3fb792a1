//! The live view: a Foxglove WebSocket server (the `foxglove` crate's) carrying every view
//! channel the recorder writes — the same messages, as they are recorded — so a run can be
//! watched in Foxglove while it flies.

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::sync::Arc;

use anyhow::{Context as _, Result, bail};
use foxglove::{ChannelBuilder, Context, PartialMetadata, RawChannel, WebSocketServer};
use recording::ViewTap;
use recording::foxglove::{VIEW_ENCODING, ViewMessage};

/// The server and one channel per view topic, created when its first message comes.
pub struct Live {
    context: Arc<Context>,
    channels: BTreeMap<String, Arc<RawChannel>>,
    /// Kept so the server lives as long as the recorder.
    _server: foxglove::WebSocketServerHandle,
}

impl Live {
    /// Serves on `addr`. Only loopback: the view shows ground truth and the server has no
    /// authentication (watch a remote host through an SSH tunnel).
    pub fn start(addr: SocketAddr, session: &str) -> Result<Self> {
        if !addr.ip().is_loopback() {
            bail!(
                "--live {addr}: the live view serves ground truth without authentication, so \
                 it listens on loopback only (watch another host through `ssh -L`)"
            );
        }
        let context = Context::new();
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
            channels: BTreeMap::new(),
            _server: server,
        })
    }
}

impl ViewTap for Live {
    fn view(&mut self, topic: &str, log_time_ns: u64, msg: &ViewMessage) {
        let channel = match self.channels.get(topic) {
            Some(c) => c.clone(),
            None => {
                let built = ChannelBuilder::new(topic)
                    .context(&self.context)
                    .message_encoding(VIEW_ENCODING)
                    .schema(msg.schema.clone())
                    .build_raw();
                match built {
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
