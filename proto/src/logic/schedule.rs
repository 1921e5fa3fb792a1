//! A performer flight schedule: setpoints as an exact function of integer sim time, plus the
//! ground-truth symbol timeline (for the record and evaluation only, never for an observer).
//!
//! A schedule is a contiguous chain of pieces — hovers and minimum-jerk strokes — starting at a
//! given sim time. Before its start and after its end the setpoint is the hover point it starts
//! and ends at. Every symbol ends exactly (bit for bit) where it started.
//!
//! Offers appended back to back share one hover: the frame parser keeps the releasing NULL of one
//! frame as the first NULL of the next, so the final NULL of offer k *is* the first NULL of offer
//! k + 1. The timeline lists that hover twice, once in each offer's 17 slots, with equal times.

use crate::{Action, Kinematics, PerformerActivity, Token};

use crate::gesture::{ACQUISITION_KEYPOINTS, GestureConfig, MotionProfile, Stroke, strokes};
use crate::min_jerk;
use crate::scene::distance_m;

/// Why a gesture or schedule cannot be built.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ScheduleError {
    #[error("a hold or motion has zero duration")]
    ZeroDuration,
    #[error("amplitudes must be finite and positive, got u {amplitude_u_m} m, v {amplitude_v_m} m")]
    BadAmplitude {
        amplitude_u_m: f64,
        amplitude_v_m: f64,
    },
    #[error("origin {origin_m:?} is not finite")]
    BadOrigin { origin_m: [f64; 3] },
    #[error("payload {payload} does not fit in 6 bits")]
    PayloadTooWide { payload: u8 },
    #[error("schedule runs past the end of representable sim time")]
    TimeOverflow,
}

/// What the performer is doing during a span of the truth timeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum TruthSymbol {
    /// A hover meant to be confirmed as NULL.
    Null,
    /// A motion symbol.
    Action(Action),
    /// The event-modality acquisition sweep (not a frame token).
    Acquisition,
}

impl TruthSymbol {
    /// The token an ideal receiver should report for this span (none for the acquisition sweep).
    pub fn token(self) -> Option<Token> {
        match self {
            TruthSymbol::Null => Some(Token::Null),
            TruthSymbol::Action(a) => Some(a.token()),
            TruthSymbol::Acquisition => None,
        }
    }

    /// The label published on `truth/performer`.
    pub fn activity(self) -> PerformerActivity {
        match self {
            TruthSymbol::Null => PerformerActivity::NullHover,
            TruthSymbol::Action(a) => PerformerActivity::Action(a),
            TruthSymbol::Acquisition => PerformerActivity::Acquisition,
        }
    }
}

/// Where a truth span sits inside a transmitted frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FrameSlot {
    /// 0-based index of the offer within the schedule.
    pub offer_index: u32,
    /// The offer's 6-bit payload (b1 most significant).
    pub payload: u8,
    /// Token position in the frame, 0..17 (0..19 or 0..23 with a check).
    pub position: u8,
}

/// One labelled interval `[start_ns, end_ns)` of the schedule.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TruthSpan {
    pub symbol: TruthSymbol,
    pub start_ns: u64,
    pub end_ns: u64,
    /// Set for spans that belong to an offer's frame.
    pub slot: Option<FrameSlot>,
}

/// An offer placed in the schedule.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScheduledOffer {
    pub payload: u8,
    /// Start of the offer's first NULL (the "offer start" of the paper's timing table).
    pub start_ns: u64,
    /// Start of the offer's final NULL hover: a receiver confirms the final NULL ≈ 3 s later.
    pub final_null_start_ns: u64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Motion {
    Hold([f64; 3]),
    Stroke { from_m: [f64; 3], to_m: [f64; 3] },
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Piece {
    start_ns: u64,
    end_ns: u64,
    motion: Motion,
}

/// A complete, immutable flight schedule.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    start_ns: u64,
    end_ns: u64,
    origin_m: [f64; 3],
    pieces: Vec<Piece>,
    timeline: Vec<TruthSpan>,
    offers: Vec<ScheduledOffer>,
    /// The check its offers' frames carry.
    frame_check: crate::frame::FrameCheck,
}

impl Schedule {
    /// Sim time of the first piece.
    pub fn start_ns(&self) -> u64 {
        self.start_ns
    }

    /// Sim time at which the last piece ends.
    pub fn end_ns(&self) -> u64 {
        self.end_ns
    }

    /// The hover point the schedule starts and ends at.
    pub fn origin_m(&self) -> [f64; 3] {
        self.origin_m
    }

    /// Ground-truth spans in time order (a NULL shared by two offers appears once per offer).
    pub fn timeline(&self) -> &[TruthSpan] {
        &self.timeline
    }

    /// The spans containing `t_ns`: none while idle, two inside a NULL shared by two offers
    /// (the earlier offer's first).
    pub fn spans_at(&self, t_ns: u64) -> impl Iterator<Item = &TruthSpan> {
        let first = self.timeline.partition_point(|sp| sp.end_ns <= t_ns);
        self.timeline[first..]
            .iter()
            .take_while(move |sp| sp.start_ns <= t_ns)
            .filter(move |sp| t_ns < sp.end_ns)
    }

    /// The offers, in transmission order.
    /// The check its offers' frames carry (what a receiver of this broadcast must parse).
    pub fn frame_check(&self) -> crate::frame::FrameCheck {
        self.frame_check
    }

    pub fn offers(&self) -> &[ScheduledOffer] {
        &self.offers
    }

    /// Commanded position at `t_ns`.
    pub fn setpoint_at(&self, t_ns: u64) -> [f64; 3] {
        self.state_at(t_ns).pos_m
    }

    /// Commanded position, velocity and acceleration at `t_ns` (for controller feed-forward).
    pub fn state_at(&self, t_ns: u64) -> Kinematics {
        let hover = |pos_m| Kinematics {
            pos_m,
            vel_mps: [0.0; 3],
            acc_mps2: [0.0; 3],
        };
        if t_ns < self.start_ns || t_ns >= self.end_ns || self.pieces.is_empty() {
            return hover(self.origin_m);
        }
        let i = self.pieces.partition_point(|p| p.start_ns <= t_ns) - 1;
        let piece = &self.pieces[i];
        match piece.motion {
            Motion::Hold(p) => hover(p),
            Motion::Stroke { from_m, to_m } => {
                let span_ns = piece.end_ns - piece.start_ns;
                let s = (t_ns - piece.start_ns) as f64 / span_ns as f64;
                let dt_s = span_ns as f64 * 1e-9;
                let (sp, sv, sa) = (
                    min_jerk::position(s),
                    min_jerk::velocity(s),
                    min_jerk::acceleration(s),
                );
                Kinematics {
                    pos_m: std::array::from_fn(|k| from_m[k] * (1.0 - sp) + to_m[k] * sp),
                    vel_mps: std::array::from_fn(|k| (to_m[k] - from_m[k]) * sv / dt_s),
                    acc_mps2: std::array::from_fn(|k| (to_m[k] - from_m[k]) * sa / (dt_s * dt_s)),
                }
            }
        }
    }

    /// Analytic peak speed (m/s) and acceleration magnitude (m/s²) over `[from_ns, to_ns)`,
    /// taken over every stroke overlapping that interval.
    pub fn peak_motion(&self, from_ns: u64, to_ns: u64) -> (f64, f64) {
        let mut peaks = (0.0f64, 0.0f64);
        for p in &self.pieces {
            if p.end_ns <= from_ns || p.start_ns >= to_ns {
                continue;
            }
            if let Motion::Stroke { from_m, to_m } = p.motion {
                let d = distance_m(from_m, to_m);
                let t = (p.end_ns - p.start_ns) as f64 * 1e-9;
                peaks.0 = peaks.0.max(min_jerk::PEAK_VELOCITY_FACTOR * d / t);
                peaks.1 = peaks
                    .1
                    .max(min_jerk::PEAK_ACCELERATION_FACTOR * d / (t * t));
            }
        }
        peaks
    }
}

/// Appends pieces to a schedule under construction.
#[derive(Debug, Clone)]
pub struct ScheduleBuilder {
    config: GestureConfig,
    /// The check each offer's frame carries.
    check: crate::frame::FrameCheck,
    schedule: Schedule,
    /// Index (in `pieces`, `timeline`) of the final NULL of the offer that ended the schedule so
    /// far, if the last thing appended was an offer.
    open_final_null: Option<(usize, usize)>,
}

impl ScheduleBuilder {
    /// An empty schedule that starts at `start_ns` hovering at `origin_m`.
    pub fn new(
        start_ns: u64,
        origin_m: [f64; 3],
        config: GestureConfig,
    ) -> Result<Self, ScheduleError> {
        config.validate()?;
        if origin_m.iter().any(|c| !c.is_finite()) {
            return Err(ScheduleError::BadOrigin { origin_m });
        }
        Ok(Self {
            config,
            check: crate::frame::FrameCheck::None,
            schedule: Schedule {
                start_ns,
                end_ns: start_ns,
                origin_m,
                pieces: Vec::new(),
                timeline: Vec::new(),
                offers: Vec::new(),
                frame_check: crate::frame::FrameCheck::None,
            },
            open_final_null: None,
        })
    }

    /// Offers appended from now on carry `check` after their payload bits.
    pub fn frame_check(&mut self, check: crate::frame::FrameCheck) -> &mut Self {
        self.check = check;
        self.schedule.frame_check = check;
        self
    }

    /// Sim time at which the next appended piece starts.
    pub fn cursor_ns(&self) -> u64 {
        self.schedule.end_ns
    }

    /// An unlabelled hover (not part of any frame).
    pub fn hover(&mut self, duration_ns: u64) -> Result<&mut Self, ScheduleError> {
        self.open_final_null = None;
        self.push_hold(duration_ns)?;
        Ok(self)
    }

    /// A hover labelled NULL in the truth timeline but outside any offer.
    pub fn null(&mut self, duration_ns: u64) -> Result<&mut Self, ScheduleError> {
        self.open_final_null = None;
        let (start_ns, end_ns) = self.push_hold(duration_ns)?;
        self.push_span(TruthSymbol::Null, start_ns, end_ns, None);
        Ok(self)
    }

    /// One motion symbol outside any offer.
    pub fn action(&mut self, action: Action) -> Result<&mut Self, ScheduleError> {
        self.open_final_null = None;
        let (start_ns, end_ns) =
            self.push_polyline(action.keypoints(), &self.config.profile(action))?;
        self.push_span(TruthSymbol::Action(action), start_ns, end_ns, None);
        Ok(self)
    }

    /// The event-modality acquisition sweep. The quiet that must follow it is the next offer's
    /// lead NULL ([`GestureConfig::lead_null_ns`]).
    pub fn acquisition(&mut self) -> Result<&mut Self, ScheduleError> {
        self.open_final_null = None;
        let profile = self.config.acquisition;
        let (start_ns, end_ns) = self.push_polyline(&ACQUISITION_KEYPOINTS, &profile)?;
        self.push_span(TruthSymbol::Acquisition, start_ns, end_ns, None);
        Ok(self)
    }

    /// One offer: `NULL START NULL b1 … NULL b6 NULL END NULL` for a 6-bit `payload`
    /// (b1 most significant), the check bits after b6 when the builder has a
    /// [`Self::frame_check`]. Directly after another offer, that offer's final NULL is
    /// stretched to [`GestureConfig::shared_null_ns`] and doubles as this offer's first NULL.
    pub fn offer(&mut self, payload: u8) -> Result<&mut Self, ScheduleError> {
        if payload >= 1 << crate::frame::FRAME_BITS {
            return Err(ScheduleError::PayloadTooWide { payload });
        }
        let offer_index =
            u32::try_from(self.schedule.offers.len()).map_err(|_| ScheduleError::TimeOverflow)?;
        let slot = |position: u8| {
            Some(FrameSlot {
                offer_index,
                payload,
                position,
            })
        };
        let lead_start_ns = match self.open_final_null.take() {
            Some((piece_i, span_i)) => {
                let start_ns = self.schedule.pieces[piece_i].start_ns;
                let end_ns = start_ns
                    .checked_add(self.config.shared_null_ns)
                    .ok_or(ScheduleError::TimeOverflow)?;
                self.schedule.pieces[piece_i].end_ns = end_ns;
                self.schedule.timeline[span_i].end_ns = end_ns;
                self.schedule.end_ns = end_ns;
                self.push_span(TruthSymbol::Null, start_ns, end_ns, slot(0));
                start_ns
            }
            None => {
                let (start_ns, end_ns) = self.push_hold(self.config.lead_null_ns)?;
                self.push_span(TruthSymbol::Null, start_ns, end_ns, slot(0));
                start_ns
            }
        };
        let bits = self
            .check
            .frame_bits(payload)
            .into_iter()
            .map(Action::for_bit);
        let actions: Vec<Action> = std::iter::once(Action::Start)
            .chain(bits)
            .chain([Action::End])
            .collect();
        let mut position = 1u8;
        for (k, &action) in actions.iter().enumerate() {
            let profile = self.config.profile(action);
            let (s, e) = self.push_polyline(action.keypoints(), &profile)?;
            self.push_span(TruthSymbol::Action(action), s, e, slot(position));
            let hold_ns = if k + 1 == actions.len() {
                self.config.final_null_ns
            } else {
                self.config.null_hold_ns
            };
            let (s, e) = self.push_hold(hold_ns)?;
            self.push_span(TruthSymbol::Null, s, e, slot(position + 1));
            position += 2;
        }
        let final_null_start_ns = self
            .schedule
            .pieces
            .last()
            .map_or(lead_start_ns, |p| p.start_ns);
        self.open_final_null = Some((
            self.schedule.pieces.len() - 1,
            self.schedule.timeline.len() - 1,
        ));
        self.schedule.offers.push(ScheduledOffer {
            payload,
            start_ns: lead_start_ns,
            final_null_start_ns,
        });
        Ok(self)
    }

    /// The finished schedule.
    pub fn build(&self) -> Schedule {
        self.schedule.clone()
    }

    fn push_hold(&mut self, duration_ns: u64) -> Result<(u64, u64), ScheduleError> {
        if duration_ns == 0 {
            return Err(ScheduleError::ZeroDuration);
        }
        let start_ns = self.schedule.end_ns;
        let end_ns = start_ns
            .checked_add(duration_ns)
            .ok_or(ScheduleError::TimeOverflow)?;
        let origin = self.schedule.origin_m;
        self.schedule.pieces.push(Piece {
            start_ns,
            end_ns,
            motion: Motion::Hold(origin),
        });
        self.schedule.end_ns = end_ns;
        Ok((start_ns, end_ns))
    }

    fn push_polyline(
        &mut self,
        keypoints: &[[f64; 2]],
        profile: &MotionProfile,
    ) -> Result<(u64, u64), ScheduleError> {
        let start_ns = self.schedule.end_ns;
        start_ns
            .checked_add(profile.duration_ns)
            .ok_or(ScheduleError::TimeOverflow)?;
        let list: Vec<Stroke> = strokes(keypoints, profile, self.schedule.origin_m);
        let mut t = start_ns;
        for s in list {
            if s.duration_ns == 0 {
                return Err(ScheduleError::ZeroDuration);
            }
            let end_ns = t + s.duration_ns;
            self.schedule.pieces.push(Piece {
                start_ns: t,
                end_ns,
                motion: Motion::Stroke {
                    from_m: s.from_m,
                    to_m: s.to_m,
                },
            });
            t = end_ns;
        }
        self.schedule.end_ns = t;
        Ok((start_ns, t))
    }

    fn push_span(
        &mut self,
        symbol: TruthSymbol,
        start_ns: u64,
        end_ns: u64,
        slot: Option<FrameSlot>,
    ) {
        self.schedule.timeline.push(TruthSpan {
            symbol,
            start_ns,
            end_ns,
            slot,
        });
    }
}

/// The paper's broadcast: [`broadcast`] with the default gesture timing and no frame check.
pub fn paper_broadcast(
    start_ns: u64,
    payloads: &[u8],
    acquisition: bool,
) -> Result<Schedule, ScheduleError> {
    broadcast(
        start_ns,
        payloads,
        acquisition,
        &GestureConfig::default(),
        crate::frame::FrameCheck::None,
    )
}

/// A whole broadcast starting at `start_ns` from the nominal hover point: optionally the event
/// acquisition sweep, then every payload as back-to-back offers, each frame carrying `check`.
pub fn broadcast(
    start_ns: u64,
    payloads: &[u8],
    acquisition: bool,
    config: &GestureConfig,
    check: crate::frame::FrameCheck,
) -> Result<Schedule, ScheduleError> {
    let mut b = ScheduleBuilder::new(start_ns, crate::scene::PERFORMER_HOVER_M, *config)?;
    b.frame_check(check);
    if acquisition {
        b.acquisition()?;
    }
    for &p in payloads {
        b.offer(p)?;
    }
    Ok(b.build())
}

/// The performer's `setpoint{k}`: where `schedule` (the last broadcast it was given, if any)
/// has it at t_k, flown level and facing +x; at rest at the hover point before any broadcast.
/// One function for the performer process and the in-process mission, so both fly the same.
pub fn performer_setpoint(schedule: Option<&Schedule>, tick: u64) -> crate::PerformerSetpoint {
    let t_ns = tick.saturating_mul(crate::TICK_NS);
    let kin = schedule.map_or(Kinematics::rest(crate::scene::PERFORMER_HOVER_M), |s| {
        s.state_at(t_ns)
    });
    crate::PerformerSetpoint::new(tick, kin, 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{FRAME_TOKENS, frame_tokens};
    use crate::gesture::{NS_PER_MS, NS_PER_S};
    use crate::scene::PERFORMER_HOVER_M;

    fn single(action: Option<Action>) -> (Schedule, u64, u64) {
        let mut b =
            ScheduleBuilder::new(7 * NS_PER_MS, PERFORMER_HOVER_M, GestureConfig::default())
                .unwrap();
        b.hover(NS_PER_S).unwrap();
        let start = b.cursor_ns();
        match action {
            Some(a) => b.action(a).unwrap(),
            None => b.acquisition().unwrap(),
        };
        let end = b.cursor_ns();
        b.hover(NS_PER_S).unwrap();
        (b.build(), start, end)
    }

    #[test]
    fn every_symbol_ends_bit_exactly_where_it_started_and_lasts_its_profile() {
        let config = GestureConfig::default();
        for a in Action::ALL.map(Some).into_iter().chain([None]) {
            let (s, start, end) = single(a);
            let want_ns = a.map_or(config.acquisition.duration_ns, |a| {
                config.profile(a).duration_ns
            });
            assert_eq!(end - start, want_ns, "{a:?}");
            for t in [
                start,
                end,
                end - 1,
                s.end_ns(),
                s.end_ns() + 5 * NS_PER_S,
                0,
            ] {
                let p = s.setpoint_at(t);
                let d = distance_m(p, PERFORMER_HOVER_M);
                assert!(d < 1e-12, "{a:?} at {t}: {p:?} is {d} m from the start");
            }
            assert_eq!(
                s.setpoint_at(end),
                PERFORMER_HOVER_M,
                "{a:?}: exact at the end"
            );
            let st = s.state_at(end - 1);
            assert!(
                st.vel_mps.iter().all(|v| v.abs() < 1e-6),
                "{a:?}: still moving {st:?}"
            );
            // The motion really leaves the hover point by its amplitude.
            let far = (start..end)
                .step_by(NS_PER_MS as usize)
                .map(|t| distance_m(s.setpoint_at(t), PERFORMER_HOVER_M))
                .fold(0.0, f64::max);
            assert!(far > 0.149, "{a:?} only reaches {far} m");
        }
    }

    #[test]
    fn symbols_are_flown_in_the_x_z_plane_with_their_keypoints() {
        let (s, start, _) = single(Some(Action::Bit1));
        let config = GestureConfig::default().profile(Action::Bit1);
        let strokes = strokes(Action::Bit1.keypoints(), &config, PERFORMER_HOVER_M);
        let apex_ns = start + strokes[0].duration_ns;
        let apex = s.setpoint_at(apex_ns);
        let want = [
            0.5 * config.amplitude_u_m,
            0.0,
            PERFORMER_HOVER_M[2] + config.amplitude_v_m,
        ];
        assert!(
            distance_m(apex, want) < 1e-12,
            "inverted V apex {apex:?}, want {want:?}"
        );
        let (s, start, end) = single(Some(Action::Start));
        for t in (start..end).step_by(10 * NS_PER_MS as usize) {
            let p = s.setpoint_at(t);
            assert_eq!([p[0], p[1]], [0.0, 0.0], "START is purely vertical");
        }
    }

    #[test]
    fn setpoints_are_smooth_and_derivatives_consistent() {
        let s = paper_broadcast(0, &[0b011010], true).unwrap();
        let dt_ns = 2 * NS_PER_MS;
        let dt = dt_ns as f64 * 1e-9;
        let (v_peak, a_peak) = s.peak_motion(0, s.end_ns());
        let mut prev = s.state_at(0);
        for t in (dt_ns..s.end_ns() + dt_ns).step_by(dt_ns as usize) {
            let cur = s.state_at(t);
            for k in 0..3 {
                let fd_v = (cur.pos_m[k] - prev.pos_m[k]) / dt;
                let mean_v = 0.5 * (cur.vel_mps[k] + prev.vel_mps[k]);
                assert!(
                    (fd_v - mean_v).abs() < 2e-3,
                    "t={t} axis {k}: {fd_v} vs {mean_v}"
                );
                let fd_a = (cur.vel_mps[k] - prev.vel_mps[k]) / dt;
                let mean_a = 0.5 * (cur.acc_mps2[k] + prev.acc_mps2[k]);
                assert!(
                    (fd_a - mean_a).abs() < 2e-2,
                    "t={t} axis {k}: {fd_a} vs {mean_a}"
                );
                assert!(cur.vel_mps[k].abs() <= v_peak + 1e-9);
                assert!(cur.acc_mps2[k].abs() <= a_peak + 1e-9);
            }
            prev = cur;
        }
    }

    #[test]
    fn broadcast_timeline_has_17_tokens_per_offer_and_long_null_holds() {
        let config = GestureConfig::default();
        let payloads = [0b011010, 0b100111, 0b010000];
        for acquisition in [false, true] {
            let s = broadcast(
                1_000,
                &payloads,
                acquisition,
                &config,
                crate::frame::FrameCheck::None,
            )
            .unwrap();
            assert_eq!(s.offers().len(), payloads.len());
            for (k, offer) in s.offers().iter().enumerate() {
                let spans: Vec<&TruthSpan> = s
                    .timeline()
                    .iter()
                    .filter(|sp| sp.slot.is_some_and(|sl| sl.offer_index == k as u32))
                    .collect();
                assert_eq!(spans.len(), FRAME_TOKENS, "offer {k}");
                let tokens: Vec<_> = spans.iter().map(|sp| sp.symbol.token().unwrap()).collect();
                assert_eq!(tokens, frame_tokens(payloads[k]).to_vec());
                for (i, sp) in spans.iter().enumerate() {
                    let slot = sp.slot.unwrap();
                    assert_eq!((slot.position as usize, slot.payload), (i, payloads[k]));
                    if sp.symbol == TruthSymbol::Null {
                        assert!(sp.end_ns - sp.start_ns >= 4_500 * NS_PER_MS, "{sp:?}");
                    }
                }
                // The offer's spans tile its interval without gaps.
                for w in spans.windows(2) {
                    assert_eq!(w[0].end_ns, w[1].start_ns);
                }
                assert_eq!(offer.start_ns, spans[0].start_ns);
                assert_eq!(offer.final_null_start_ns, spans[16].start_ns);
                assert_eq!(offer.payload, payloads[k]);
            }
            // Back-to-back offers share one hover: same interval as final and first NULL.
            for k in 1..payloads.len() {
                let last = s.timeline().iter().find(|sp| {
                    sp.slot
                        .is_some_and(|sl| sl.offer_index == k as u32 - 1 && sl.position == 16)
                });
                let first = s.timeline().iter().find(|sp| {
                    sp.slot
                        .is_some_and(|sl| sl.offer_index == k as u32 && sl.position == 0)
                });
                let (last, first) = (last.unwrap(), first.unwrap());
                assert_eq!((last.start_ns, last.end_ns), (first.start_ns, first.end_ns));
                assert_eq!(last.end_ns - last.start_ns, config.shared_null_ns);
            }
            let acq: Vec<_> = s
                .timeline()
                .iter()
                .filter(|sp| sp.symbol == TruthSymbol::Acquisition)
                .collect();
            assert_eq!(acq.len(), usize::from(acquisition));
            if let Some(a) = acq.first() {
                assert_eq!(a.start_ns, 1_000);
                assert_eq!(
                    a.end_ns,
                    s.offers()[0].start_ns,
                    "the quiet is the first NULL"
                );
                assert_eq!(config.lead_null_ns, 6 * NS_PER_S, "paper: 6 s of quiet");
            }
            assert_eq!(s.timeline().last().unwrap().end_ns, s.end_ns());
            assert!(
                s.timeline()
                    .windows(2)
                    .all(|w| w[0].start_ns <= w[1].start_ns)
            );
        }
    }

    #[test]
    fn spans_at_finds_the_covering_spans() {
        let s = paper_broadcast(NS_PER_S, &[0b011010, 0b100111], true).unwrap();
        assert_eq!(s.spans_at(0).count(), 0, "idle before the broadcast");
        assert_eq!(s.spans_at(s.end_ns()).count(), 0, "idle after it");
        let first: Vec<_> = s.spans_at(NS_PER_S).collect();
        assert_eq!(first.len(), 1);
        assert_eq!(first[0].symbol.activity(), PerformerActivity::Acquisition);
        let shared_ns = s.offers()[1].start_ns + NS_PER_S;
        let shared: Vec<_> = s.spans_at(shared_ns).map(|sp| sp.slot.unwrap()).collect();
        assert_eq!(shared.len(), 2);
        assert_eq!((shared[0].offer_index, shared[0].position), (0, 16));
        assert_eq!((shared[1].offer_index, shared[1].position), (1, 0));
        for t in (0..s.end_ns()).step_by(37 * NS_PER_MS as usize) {
            let brute = s
                .timeline()
                .iter()
                .filter(|sp| (sp.start_ns..sp.end_ns).contains(&t));
            assert!(brute.eq(s.spans_at(t)), "t = {t}");
        }
    }

    #[test]
    fn one_offer_lasts_the_documented_98_s() {
        let s = paper_broadcast(0, &[0b100111], false).unwrap();
        assert_eq!(s.end_ns(), 98_000 * NS_PER_MS);
        assert_eq!(s.offers()[0].final_null_start_ns, 93_000 * NS_PER_MS);
        // Sweep, then the first offer with its final NULL stretched to the shared 6 s, then the
        // second offer without a lead NULL of its own.
        let s2 = paper_broadcast(0, &[0b100111, 0b011010], true).unwrap();
        assert_eq!(s2.end_ns(), (4_000 + 99_000 + 92_000) * NS_PER_MS);
    }

    #[test]
    fn a_checked_frame_flies_its_check_bits_before_end() {
        use crate::frame::FrameCheck;
        let c = GestureConfig::default();
        let plain = broadcast(0, &[0b010000], false, &c, FrameCheck::None).unwrap();
        for check in [FrameCheck::Parity, FrameCheck::Crc3] {
            let s = broadcast(0, &[0b010000], false, &c, check).unwrap();
            let tokens: Vec<Token> = s
                .timeline()
                .iter()
                .filter_map(|sp| sp.symbol.token())
                .collect();
            assert_eq!(tokens, check.tokens_of(0b010000), "{check}");
            let per_bit_ns = c.profile(Action::Bit0).duration_ns + c.null_hold_ns;
            assert_eq!(
                s.end_ns(),
                plain.end_ns() + check.bits() as u64 * per_bit_ns
            );
            let last = s.timeline().last().and_then(|sp| sp.slot).unwrap();
            assert_eq!(usize::from(last.position) + 1, check.frame_tokens());
        }
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let c = GestureConfig::default();
        assert_eq!(
            broadcast(0, &[64], false, &c, crate::frame::FrameCheck::None).unwrap_err(),
            ScheduleError::PayloadTooWide { payload: 64 }
        );
        assert_eq!(
            broadcast(
                u64::MAX - 10,
                &[1],
                false,
                &c,
                crate::frame::FrameCheck::None
            )
            .unwrap_err(),
            ScheduleError::TimeOverflow
        );
        let mut z = c;
        z.null_hold_ns = 0;
        assert_eq!(
            broadcast(0, &[1], false, &z, crate::frame::FrameCheck::None).unwrap_err(),
            ScheduleError::ZeroDuration
        );
        let mut a = c;
        a.actions[2].amplitude_u_m = f64::NAN;
        assert!(matches!(
            broadcast(0, &[1], false, &a, crate::frame::FrameCheck::None),
            Err(ScheduleError::BadAmplitude { .. })
        ));
        assert!(matches!(
            ScheduleBuilder::new(0, [0.0, f64::INFINITY, 1.0], c),
            Err(ScheduleError::BadOrigin { .. })
        ));
    }
}
