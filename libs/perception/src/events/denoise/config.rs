//! The noise front end's settings: the neighbourhood, the window, the support asked (fixed or
//! set from the measured background), and the counts it reports.

use crate::events::error::EventReceiverError;

/// Largest supported neighbourhood radius.
pub const MAX_RADIUS_PX: u16 = 2;
/// Most events remembered per pixel.
pub const MAX_DEPTH: usize = 2;

/// Noise front-end settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DenoiseConfig {
    /// Neighbourhood radius r (Chebyshev), pixels: `(2r+1)² − 1` neighbours. 1 or 2.
    pub radius_px: u16,
    /// Two neighbours' events are correlated when at most this far apart in time.
    pub window_ns: u64,
    /// Fewest correlated neighbour events that make an event a *core* event, kept (0: filter
    /// off). With [`DenoiseConfig::adaptive`], the most the filter will ask for.
    pub min_neighbours: u8,
    /// Also keep *border* events: those with a core event among their neighbours within the
    /// window (density clustering's border points: the ends and corners of an edge).
    pub border: bool,
    /// Events remembered per neighbour pixel, 1 or 2: with 2, a neighbour that fired twice
    /// within the window counts twice (a strong edge fires several events per pixel; noise
    /// rarely fires twice).
    pub depth: u8,
    /// Ask only for the support the measured background needs (see [`Adaptive`]); `None`: always
    /// `min_neighbours`.
    pub adaptive: Option<Adaptive>,
}

/// How the receiver sets its support from the measured background rate r
/// ([`crate::events::background`]): the least k (up to [`DenoiseConfig::min_neighbours`]) for
/// which the noise expected to survive inside the tracking window stays within the budget,
/// `r · window_px · T · P(Poisson(2·W·r·N) ≥ k) ≤ budget_events` (T the packet period, W the
/// correlation window, N the neighbours). With no background the support is 0 and every event
/// passes: a noiseless sensor's stream reaches the tracker untouched.
///
/// Past [`Adaptive::once_support`] the support starts removing the target's own pixels that
/// fire only once within the window, so it goes beyond that only when it must: when that
/// support would leave more than [`Adaptive::tolerated_events`] noise events per packet in the
/// window, more than the tracker can absorb. Then it rises to whatever meets the budget.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Adaptive {
    /// Noise events the tracker may see inside its window per packet.
    pub budget_events: f64,
    /// Pixels of the tracking window.
    pub window_px: u32,
    /// The most support a patch of target pixels that each fire once can give.
    pub once_support: u8,
    /// Noise events per packet inside the window the tracker still absorbs: the support stays
    /// at `once_support` while no more than this many are expected to survive it.
    pub tolerated_events: f64,
}

impl DenoiseConfig {
    /// The receiver's front end: 8 neighbours, two events each, ±15 ms, borders, and a support
    /// set from the measured background, so that one noise event per hundred packets (4 s) is
    /// expected to survive inside the ±64×±48 px tracking window: a couple of stray pixels are
    /// enough to turn a target's sparse tail into a supported, displaced estimate (measured:
    /// unfiltered, 0.0003 Hz per pixel already cost 11 of 100 trials).
    ///
    /// Chosen on the receiver's own terms, not on any sensor preset. Support 8 is the most a
    /// patch of pixels that each fire once can give, and up to ≈ 6.8 Hz per pixel it is where
    /// the support stops: on generated streams (`libs/perception/tests/denoise.rs`, whose ROC it
    /// prints) it removes 99.98 % of 5 Hz noise, a smaller support let clumps survive that moved
    /// the tracker's percentile centre by up to 18 px, and a larger one (10, what the budget
    /// alone asks for at 5 Hz) kept only 92.5 % of a target and lost a bit of a 5 Hz frame.
    /// Beyond 8 the support goes only when 8 would leave more than one noise event per packet
    /// in the window (the percentile centre absorbs a few: 2.5 % of a target's ≈ 200 pixels),
    /// up to 16, all that 8 neighbours remembering two events each can give: at 10 Hz per pixel,
    /// the dim-light figure of a real DAVIS346, support 8 let ≈ 1 % of the noise through, its
    /// survivors lit enough of the sensor's 32 px cells to be read as broad scene activity in
    /// every packet and a whole frame gave no token; support 13 decodes it (a moving edge fires
    /// several events per pixel). Where the background is not uniform the model under-counts
    /// what survives; the filter then measures it (module `escalation`). A fixed support 8 also
    /// removed 5.6 % of a real drone's
    /// noiseless events and lost every message of an observer at 40°: the adaptive support is
    /// 0 on a noiseless sensor.
    pub fn receiver() -> Self {
        Self {
            radius_px: 1,
            window_ns: 15_000_000,
            min_neighbours: 16,
            border: true,
            depth: 2,
            adaptive: Some(Adaptive {
                budget_events: 0.01,
                window_px: 129 * 97,
                once_support: 8,
                tolerated_events: 1.0,
            }),
        }
    }

    /// No filtering at all (every event kept).
    pub fn off() -> Self {
        Self {
            radius_px: 1,
            window_ns: 0,
            min_neighbours: 0,
            border: false,
            depth: 1,
            adaptive: None,
        }
    }

    /// The support this configuration asks for against a background of `rate_hz` per pixel
    /// with packets of `packet_ns`: the budget's, held at [`Adaptive::once_support`] while that
    /// is modelled to leave at most [`Adaptive::tolerated_events`] noise events.
    pub fn support_for(&self, rate_hz: f64, packet_ns: u64) -> u8 {
        let (budget, at_once) = self.supports(rate_hz, packet_ns);
        match (self.adaptive, at_once) {
            (Some(a), Some(noise)) if budget > a.once_support && noise <= a.tolerated_events => {
                a.once_support
            }
            _ => budget,
        }
    }

    /// The support the budget alone asks for (past [`Adaptive::once_support`] whenever it
    /// must): what the filter uses once it has *measured* more survivors at
    /// `once_support` than the tracker absorbs.
    pub fn budget_support(&self, rate_hz: f64, packet_ns: u64) -> u8 {
        self.supports(rate_hz, packet_ns).0
    }

    /// (the least support meeting the budget, the noise modelled to survive
    /// `once_support` inside the window per packet, if the search reached it).
    fn supports(&self, rate_hz: f64, packet_ns: u64) -> (u8, Option<f64>) {
        let Some(a) = self.adaptive else {
            return (self.min_neighbours, None);
        };
        let arriving = rate_hz * f64::from(a.window_px) * packet_ns as f64 * 1e-9;
        let mean = 2.0 * self.window_ns as f64 * 1e-9 * rate_hz * self.neighbours() as f64;
        // P(Poisson(mean) ≥ k) for k = 0, 1, …: 1 minus the running sum of the terms.
        let (mut term, mut below): (f64, f64) = ((-mean).exp(), 0.0);
        let mut at_once = None;
        for k in 0..self.min_neighbours {
            let surviving = arriving * (1.0 - below).max(0.0);
            if k == a.once_support {
                at_once = Some(surviving);
            }
            if surviving <= a.budget_events {
                return (k, at_once);
            }
            below += term;
            term *= mean / f64::from(k + 1);
        }
        (self.min_neighbours, at_once)
    }

    /// Neighbours in the neighbourhood: `(2r+1)² − 1`.
    pub fn neighbours(&self) -> usize {
        let side = 2 * usize::from(self.radius_px) + 1;
        side * side - 1
    }

    /// Rejects settings the filter cannot run with.
    pub fn validate(&self) -> Result<(), EventReceiverError> {
        if self.radius_px == 0 || self.radius_px > MAX_RADIUS_PX {
            return Err(EventReceiverError::BadSetting {
                setting: "denoise.radius_px",
                reason: format!("{} is outside 1..={MAX_RADIUS_PX}", self.radius_px),
            });
        }
        if !(1..=MAX_DEPTH).contains(&usize::from(self.depth)) {
            return Err(EventReceiverError::BadSetting {
                setting: "denoise.depth",
                reason: format!("{} is outside 1..={MAX_DEPTH}", self.depth),
            });
        }
        if usize::from(self.min_neighbours) > usize::from(self.depth) * self.neighbours() {
            return Err(EventReceiverError::BadSetting {
                setting: "denoise.min_neighbours",
                reason: format!(
                    "{} exceeds the {} neighbours of radius {}",
                    self.min_neighbours,
                    self.neighbours(),
                    self.radius_px
                ),
            });
        }
        Ok(())
    }
}

impl Default for DenoiseConfig {
    fn default() -> Self {
        Self::receiver()
    }
}

/// Events seen and removed by the front end.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DenoiseCounts {
    pub seen: u64,
    pub removed: u64,
}
