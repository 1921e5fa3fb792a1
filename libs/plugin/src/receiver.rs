//! One observer's receiver on a plug-in worker, at the plug-in's level. Below the level the
//! plug-in replaces, Waggle's own chain decodes: a tracker's points go through the segmenter
//! and frame parser as the ideal baseline's do; a token receiver's tokens through the frame
//! parser; a full receiver's frames are taken as released. Every output is checked (stamps in
//! order, none after its input, payloads of six bits) before it counts.

use std::cell::RefCell;
use std::rc::Rc;

use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, Placement, focal_px};
use proto::{
    DecodeStep, Decoder, EgoRotation, EventPacket, FrameParser, Modality, Rectification, RgbFrame,
    Sample, SegmentToken, SegmenterConfig, TokenCause,
};
use serde::Serialize;
use serde_json::{Value, json};

use crate::error::PluginError;
use crate::wire;
use crate::worker::Worker;

/// What a plug-in replaces of Waggle's receiving chain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Level {
    /// Sensor input → the target's image position per input.
    Tracker,
    /// Sensor input → motion tokens.
    Tokens,
    /// Sensor input → tokens and released frames.
    Full,
}

/// What a plug-in is told of the observer it serves when an instance is made for it.
#[derive(Debug, Clone, Serialize)]
pub struct ObserverInfo {
    pub name: String,
    pub modality: Modality,
    /// Where the observer's airframe sits and looks (as `trials.json` places it).
    pub home_m: [f64; 3],
    pub yaw_rad: f64,
    pub pitch_rad: f64,
    /// The receivers' viewpoint rectification (`off`, `pitched`, `frontal`).
    pub rectification: String,
    pub width_px: u16,
    pub height_px: u16,
    /// Pinhole intrinsics of the observer's camera.
    pub focal_px: f64,
    pub principal_point_px: [f64; 2],
    /// The trial's seed, for a plug-in that draws random numbers.
    pub seed: u64,
}

impl ObserverInfo {
    pub fn new(
        name: String,
        modality: Modality,
        placement: &Placement,
        rectification: Rectification,
        seed: u64,
    ) -> Self {
        Self {
            name,
            modality,
            home_m: placement.home_m,
            yaw_rad: placement.yaw_rad,
            pitch_rad: placement.pitch_rad,
            rectification: format!("{rectification:?}").to_lowercase(),
            width_px: IMAGE_WIDTH_PX,
            height_px: IMAGE_HEIGHT_PX,
            focal_px: focal_px(),
            principal_point_px: [
                f64::from(IMAGE_WIDTH_PX) / 2.0,
                f64::from(IMAGE_HEIGHT_PX) / 2.0,
            ],
            seed,
        }
    }
}

/// What a plug-in reports of the events it saw, as Waggle's event receiver reports its noise
/// and ego-motion front ends.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PluginCounts {
    pub events_received: Option<u64>,
    pub events_removed: Option<u64>,
    pub events_removed_ego: Option<u64>,
}

/// The part of Waggle's chain below the plug-in.
#[derive(Debug)]
enum Below {
    Decoder(Box<Decoder>),
    Parser(FrameParser),
    Nothing,
}

/// What a plug-in made of one input: the step below its level, and where it placed the target
/// (`None`: nowhere, or it does not say).
pub type Pushed = (DecodeStep, Option<[f64; 2]>);

/// One observer's plug-in receiver.
pub struct PluginReceiver {
    worker: Rc<RefCell<Worker>>,
    observer: String,
    level: Level,
    below: Below,
    ego: Option<EgoRotation>,
    /// The stamp of the latest token or frame taken, so a later one cannot go back in time.
    last_ns: u64,
}

impl PluginReceiver {
    /// Makes the plug-in's instance for `info` on `worker`; `segmenter` is the segmenter a
    /// tracker's points go through (unused at the other levels).
    pub fn open(
        worker: Rc<RefCell<Worker>>,
        info: &ObserverInfo,
        segmenter: SegmenterConfig,
    ) -> Result<Self, PluginError> {
        let header = json!({"op": "open", "observer": info.name, "info": info});
        let value = worker.borrow_mut().call(&info.name, "open", &header, &[])?;
        let level = match value.get("level").and_then(Value::as_str) {
            Some("tracker") => Level::Tracker,
            Some("tokens") => Level::Tokens,
            Some("full") => Level::Full,
            other => {
                return Err(worker.borrow().malformed(
                    &info.name,
                    "open",
                    format!("level is {other:?}, not \"tracker\", \"tokens\" or \"full\""),
                ));
            }
        };
        let below = match level {
            Level::Tracker => {
                Below::Decoder(Box::new(Decoder::new(segmenter).map_err(|e| {
                    worker.borrow().malformed(&info.name, "open", e.to_string())
                })?))
            }
            Level::Tokens => Below::Parser(FrameParser::new()),
            Level::Full => Below::Nothing,
        };
        Ok(Self {
            worker,
            observer: info.name.clone(),
            level,
            below,
            ego: None,
            last_ns: 0,
        })
    }

    pub fn level(&self) -> Level {
        self.level
    }

    /// How far the airframe has turned from home, from the next input on (handed to the
    /// plug-in with each input, and to the segmenter below a tracker).
    pub fn set_ego_rotation(&mut self, ego: Option<EgoRotation>) {
        self.ego = ego;
        if let Below::Decoder(d) = &mut self.below {
            d.set_ego_rotation(ego);
        }
    }

    /// The check the session's frames carry, for the parser below a tracker or token plug-in.
    /// A full plug-in releases frames itself, so it must parse them with the same check.
    pub fn set_frame_check(&mut self, check: proto::FrameCheck) {
        match &mut self.below {
            Below::Decoder(d) => d.set_frame_check(check),
            Below::Parser(p) => *p = FrameParser::with_check(check),
            Below::Nothing => {}
        }
    }

    /// One event packet: the step, and where the plug-in placed the target for it (a
    /// tracker's point, or the optional `point_px` of a token or full receiver).
    pub fn push_events(&mut self, packet: &EventPacket) -> Result<Pushed, PluginError> {
        let ego = self.ego.map(|e| e.world_from_home);
        let header = wire::events_header(&self.observer, packet, ego);
        let value = self.call("push", &header, &wire::events_bulk(packet))?;
        self.take(value, packet.end_ns)
    }

    /// One RGB frame (as [`Self::push_events`]).
    pub fn push_rgb(&mut self, frame: &RgbFrame) -> Result<Pushed, PluginError> {
        let ego = self.ego.map(|e| e.world_from_home);
        let header = wire::rgb_header(&self.observer, frame, ego);
        let value = self.call("push", &header, &frame.rgb)?;
        self.take(value, frame.stamp_ns)
    }

    /// A new round or reception window: the plug-in and the chain below it forget.
    pub fn reset(&mut self) -> Result<(), PluginError> {
        let header = json!({"op": "reset", "observer": self.observer});
        self.call("reset", &header, &[])?;
        match &mut self.below {
            Below::Decoder(d) => d.reset(),
            Below::Parser(p) => p.interrupt(),
            Below::Nothing => {}
        }
        Ok(())
    }

    /// The sensor stream is known to be missing at `stamp_ns`.
    pub fn missing(&mut self, stamp_ns: u64) -> Result<DecodeStep, PluginError> {
        let header = json!({"op": "missing", "observer": self.observer, "stamp_ns": stamp_ns});
        let value = self.call("missing", &header, &[])?;
        let mut step = match &mut self.below {
            Below::Decoder(d) => d
                .interrupt(stamp_ns)
                .map_err(|e| self.malformed("missing", e.to_string()))?,
            Below::Parser(p) => {
                p.interrupt();
                DecodeStep::default()
            }
            Below::Nothing => DecodeStep::default(),
        };
        if self.level != Level::Tracker {
            let (more, _) = self.take(value, stamp_ns)?;
            step.tokens.extend(more.tokens);
            step.frames.extend(more.frames);
        }
        Ok(step)
    }

    /// Tells the plug-in its observer is done (its instance is dropped), returning the counts
    /// it reports of the events it saw and removed (all `None` when it reports none).
    pub fn close(self) -> Result<PluginCounts, PluginError> {
        let header = json!({"op": "close", "observer": self.observer});
        let value = self.call("close", &header, &[])?;
        let counts = value.get("counts").unwrap_or(&Value::Null);
        let count = |key: &str| -> Result<Option<u64>, PluginError> {
            match counts.get(key) {
                None | Some(Value::Null) => Ok(None),
                Some(v) => v.as_u64().map(Some).ok_or_else(|| {
                    self.malformed("close", format!("count {key} is not a whole number: {v}"))
                }),
            }
        };
        Ok(PluginCounts {
            events_received: count("events_received")?,
            events_removed: count("events_removed")?,
            events_removed_ego: count("events_removed_ego")?,
        })
    }

    fn call(&self, call: &str, header: &Value, bulk: &[u8]) -> Result<Value, PluginError> {
        self.worker
            .borrow_mut()
            .call(&self.observer, call, header, bulk)
    }

    fn malformed(&self, call: &str, why: String) -> PluginError {
        self.worker.borrow().malformed(&self.observer, call, why)
    }

    /// The plug-in's output for an input that ended at `stamp_ns`, through the chain below.
    fn take(&mut self, value: Value, stamp_ns: u64) -> Result<Pushed, PluginError> {
        let point = wire::parse_point(value.get("point_px").unwrap_or(&Value::Null))
            .map_err(|why| self.malformed("push", why))?;
        if self.level == Level::Tracker {
            let sample = match point {
                Some(p) => Sample::tracked(stamp_ns, p),
                None => Sample::lost(stamp_ns),
            };
            let Below::Decoder(d) = &mut self.below else {
                unreachable!("a tracker decodes below")
            };
            let step = d
                .push(sample)
                .map_err(|e| self.malformed("push", e.to_string()))?;
            return Ok((step, point));
        }
        let empty = Value::Array(Vec::new());
        let tokens = wire::parse_tokens(
            value.get("tokens").unwrap_or(&empty),
            self.last_ns,
            stamp_ns,
        )
        .map_err(|why| self.malformed("push", why))?;
        let mut step = DecodeStep {
            tokens: tokens
                .iter()
                .map(|&(token, stamp_ns)| SegmentToken {
                    token,
                    stamp_ns,
                    cause: TokenCause::External,
                    late: false,
                })
                .collect(),
            frames: Vec::new(),
        };
        if let Some(&(_, t)) = tokens.last() {
            self.last_ns = t;
        }
        match &mut self.below {
            Below::Parser(p) => {
                step.frames = tokens.iter().filter_map(|&(t, s)| p.push(t, s)).collect();
            }
            _ => {
                step.frames = wire::parse_frames(value.get("frames").unwrap_or(&empty), stamp_ns)
                    .map_err(|why| self.malformed("push", why))?;
            }
        }
        Ok((step, point))
    }
}
