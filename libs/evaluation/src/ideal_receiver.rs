//! The ideal-message baseline (evaluation only).
//!
//! Projects the performer's ground-truth position into each observer's camera and runs the same
//! segmenter, template matcher and frame parser as the real receivers. It is the upper bound the
//! paper asks for: perfect tracking, no sensor. It must never run inside an observer process —
//! it reads ground truth — which is why it lives in the evaluation crate.

use proto::ReleasedFrame;
use proto::scene::{
    Formation, IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, MAX_OBSERVERS, ObserverCamera, observer_name,
};
use proto::{Decoder, Rectification, Sample, SegmentToken, SegmenterConfig, SegmenterError};

use proto::schedule::Schedule;

/// Everything one observer's ideal chain produced so far.
#[derive(Debug, Clone, PartialEq)]
pub struct ObserverOutput {
    /// `O1`, `O2`, …
    pub name: String,
    pub tokens: Vec<SegmentToken>,
    pub frames: Vec<ReleasedFrame>,
}

impl ObserverOutput {
    /// Released payloads in order.
    pub fn payloads(&self) -> Vec<u8> {
        self.frames.iter().map(|f| f.payload).collect()
    }
}

/// Why the ideal receiver refused an input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IdealReceiverError {
    #[error("observer count {n} is outside 1..={MAX_OBSERVERS}")]
    BadObserverCount { n: usize },
    #[error("no observer with index {index}")]
    UnknownObserver { index: usize },
    #[error("performer position {position_m:?} is not finite")]
    NonFinitePosition { position_m: [f64; 3] },
    #[error("sample period must be positive")]
    ZeroPeriod,
    #[error(transparent)]
    Segmenter(#[from] SegmenterError),
}

#[derive(Debug, Clone)]
struct Chain {
    camera: ObserverCamera,
    decoder: Decoder,
    output: ObserverOutput,
}

/// Ideal receivers for every observer at its home.
#[derive(Debug, Clone)]
pub struct IdealReceiver {
    chains: Vec<Chain>,
}

impl IdealReceiver {
    /// `n` observers at their homes in the built-in formation, each with the given segmenter
    /// settings.
    pub fn new(n: usize, config: SegmenterConfig) -> Result<Self, IdealReceiverError> {
        let formation =
            Formation::standard(n).map_err(|_| IdealReceiverError::BadObserverCount { n })?;
        Self::with_formation(&formation, config, Rectification::default())
    }

    /// One ideal chain per observer of `formation`, each looking from its home and matching
    /// its trajectory rectified by `rectification`.
    pub fn with_formation(
        formation: &Formation,
        config: SegmenterConfig,
        rectification: Rectification,
    ) -> Result<Self, IdealReceiverError> {
        let chains = formation
            .placements()
            .iter()
            .enumerate()
            .map(|(i, p)| {
                Ok(Chain {
                    camera: p.camera(),
                    decoder: Decoder::new(config.rectified(p.camera(), rectification))?,
                    output: ObserverOutput {
                        name: observer_name(i),
                        tokens: Vec::new(),
                        frames: Vec::new(),
                    },
                })
            })
            .collect::<Result<_, SegmenterError>>()?;
        Ok(Self { chains })
    }

    /// Parses frames carrying `check` from now on (the broadcast's own, before its first sample).
    pub fn set_frame_check(&mut self, check: proto::FrameCheck) {
        for chain in &mut self.chains {
            chain.decoder.set_frame_check(check);
        }
    }

    /// One synchronous camera instant: the performer's true position at `stamp_ns`. A position
    /// that projects outside an observer's image is a lost sample for that observer.
    pub fn push(&mut self, stamp_ns: u64, performer_m: [f64; 3]) -> Result<(), IdealReceiverError> {
        if performer_m.iter().any(|c| !c.is_finite()) {
            return Err(IdealReceiverError::NonFinitePosition {
                position_m: performer_m,
            });
        }
        for chain in &mut self.chains {
            let sample = ideal_sample(&chain.camera, stamp_ns, performer_m);
            let step = chain.decoder.push(sample)?;
            chain.output.tokens.extend(step.tokens);
            chain.output.frames.extend(step.frames);
        }
        Ok(())
    }

    /// Missing input for observer `index` at `stamp_ns` (a fault injected by a test or harness).
    pub fn interrupt(&mut self, index: usize, stamp_ns: u64) -> Result<(), IdealReceiverError> {
        let chain = self
            .chains
            .get_mut(index)
            .ok_or(IdealReceiverError::UnknownObserver { index })?;
        let step = chain.decoder.interrupt(stamp_ns)?;
        chain.output.tokens.extend(step.tokens);
        chain.output.frames.extend(step.frames);
        Ok(())
    }

    /// Outputs per observer, O1 first.
    pub fn outputs(&self) -> Vec<&ObserverOutput> {
        self.chains.iter().map(|c| &c.output).collect()
    }

    /// Output of observer `index`.
    pub fn output(&self, index: usize) -> Option<&ObserverOutput> {
        self.chains.get(index).map(|c| &c.output)
    }

    /// Feeds the schedule's setpoints (as if flown perfectly) at every multiple of `period_ns`
    /// in `[from_ns, to_ns)`.
    pub fn run_setpoints(
        &mut self,
        schedule: &Schedule,
        from_ns: u64,
        to_ns: u64,
        period_ns: u64,
    ) -> Result<(), IdealReceiverError> {
        if period_ns == 0 {
            return Err(IdealReceiverError::ZeroPeriod);
        }
        let mut t = from_ns.div_ceil(period_ns) * period_ns;
        while t < to_ns {
            self.push(t, schedule.setpoint_at(t))?;
            t += period_ns;
        }
        Ok(())
    }
}

/// What a perfect tracker on `camera` reports at `stamp_ns` with the performer at
/// `performer_m`: its projection, or a lost sample when it falls outside the image. The one
/// projection of the ideal baseline (this receiver and the in-process mission's observers).
pub fn ideal_sample(camera: &ObserverCamera, stamp_ns: u64, performer_m: [f64; 3]) -> Sample {
    match camera.project_px(performer_m).filter(|p| in_image(*p)) {
        Some(p) => Sample::tracked(stamp_ns, p),
        None => Sample::lost(stamp_ns),
    }
}

fn in_image(p: [f64; 2]) -> bool {
    (0.0..f64::from(IMAGE_WIDTH_PX)).contains(&p[0])
        && (0.0..f64::from(IMAGE_HEIGHT_PX)).contains(&p[1])
}
