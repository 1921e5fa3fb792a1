//! Raising the support on what is *measured* to survive it, not only on what is modelled.
//!
//! The adaptive support ([`DenoiseConfig::support_for`]) models a noise event's support as a
//! Poisson count over pixels at the median cell's rate. A real sensor's background is not
//! uniform: v2e drops shot noise in bright pixels (to 0.25×) and scales each pixel's rate by
//! `C/C_i`, so the scene's dark parts fire faster than the median says. Measured on a generated
//! stream with `dvs-dim`'s terms: at support 8 the model predicts 0.96 noise events per packet
//! inside the tracking window, ≈ 5–7 survive. So while the support is
//! [`Adaptive::once_support`], the filter also counts what it *kept*, per 32 px cell over one
//! second, and takes the median cell (the background estimate's method: a target fills a few
//! cells and cannot move it). When that exceeds [`Adaptive::tolerated_events`] per window and
//! packet, the support is set by the budget alone from then on, until the background falls
//! below what asks for `once_support` at all.
//!
//! One step, not a controller: the median cell sees the excess only while it covers most of
//! the sensor, and a support raised by feedback until the median is quiet was not measured on
//! real renders (`docs/decisions/v2e-sensor-model.md`, `dvs-dim`).

use crate::events::background::BackgroundEstimate;
use crate::events::denoise::config::{Adaptive, DenoiseConfig};

/// Measured survivors and whether they raised the support.
#[derive(Debug, Clone)]
pub(super) struct Escalation {
    /// Events kept at `once_support`, per cell, over the last second at that support.
    survivors: BackgroundEstimate,
    packets: usize,
    escalated: bool,
}

impl Escalation {
    pub(super) fn new(width: u16, height: u16, packets: usize) -> Self {
        Self {
            survivors: BackgroundEstimate::new(width, height, packets),
            packets,
            escalated: false,
        }
    }

    /// The support for the next packet against a measured background of `rate_hz`.
    pub(super) fn support(&mut self, config: &DenoiseConfig, rate_hz: f64, packet_ns: u64) -> u8 {
        let modelled = config.support_for(rate_hz, packet_ns);
        let Some(a) = config.adaptive else {
            return modelled;
        };
        if self.escalated && modelled < a.once_support {
            // The background no longer asks for `once_support`: what was measured there is
            // out of date.
            self.escalated = false;
        }
        if self.escalated {
            config.budget_support(rate_hz, packet_ns)
        } else {
            modelled
        }
    }

    /// What the packet kept at support `k`: measured when `k` is `once_support`.
    pub(super) fn observe(
        &mut self,
        config: &DenoiseConfig,
        k: u8,
        packet_ns: u64,
        kept: impl Iterator<Item = (u16, u16)>,
    ) {
        let Some(Adaptive {
            once_support,
            tolerated_events,
            window_px,
            ..
        }) = config.adaptive
        else {
            return;
        };
        if self.escalated || k != once_support {
            self.survivors.clear();
            return;
        }
        self.survivors.add(packet_ns, kept);
        if self.survivors.packets() >= self.packets {
            let per_window =
                self.survivors.rate_hz() * f64::from(window_px) * packet_ns as f64 * 1e-9;
            if per_window > tolerated_events {
                self.escalated = true;
                self.survivors.clear();
            }
        }
    }

    /// Whether measured survivors have raised the support.
    pub(super) fn escalated(&self) -> bool {
        self.escalated
    }

    /// Forgets everything (a restarted stream).
    pub(super) fn clear(&mut self) {
        self.survivors.clear();
        self.escalated = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PACKET_NS: u64 = 40_000_000;

    /// `per_cell` kept events in every 32 px cell of a 640×480 sensor.
    fn spread(per_cell: u16) -> impl Iterator<Item = (u16, u16)> {
        (0..20u16).flat_map(move |cx| {
            (0..15u16).flat_map(move |cy| (0..per_cell).map(move |i| (cx * 32 + i, cy * 32 + i)))
        })
    }

    #[test]
    fn survivors_measured_above_the_tolerance_raise_the_support_until_the_background_falls() {
        let config = DenoiseConfig::receiver();
        let mut e = Escalation::new(640, 480, 25);
        // 6.5 Hz per pixel: the model holds the support at 8.
        assert_eq!(e.support(&config, 6.5, PACKET_NS), 8);
        // One kept event per cell and packet: 12 513 / 1 024 ≈ 12 per window, far above 1.
        for _ in 0..24 {
            e.observe(&config, 8, PACKET_NS, spread(1));
            assert!(!e.escalated(), "a second is measured before deciding");
        }
        e.observe(&config, 8, PACKET_NS, spread(1));
        assert!(e.escalated());
        let raised = e.support(&config, 6.5, PACKET_NS);
        assert_eq!(raised, config.budget_support(6.5, PACKET_NS));
        assert!(raised > 8, "{raised}");
        // A background that no longer asks for 8 ends it.
        assert!(e.support(&config, 1.0, PACKET_NS) < 8);
        assert!(!e.escalated());
        assert_eq!(e.support(&config, 6.5, PACKET_NS), 8);
    }

    #[test]
    fn few_survivors_or_another_support_leave_the_model_in_charge() {
        let config = DenoiseConfig::receiver();
        let mut e = Escalation::new(640, 480, 25);
        // Nothing kept outside a target's few cells: the median cell is empty.
        for _ in 0..100 {
            e.observe(&config, 8, PACKET_NS, (0..400u16).map(|i| (i % 60, i / 60)));
        }
        assert!(!e.escalated());
        // Many survivors, but measured at another support: not counted.
        for _ in 0..100 {
            e.observe(&config, 5, PACKET_NS, spread(3));
        }
        assert!(!e.escalated());
        // A support that changes before a second is measured restarts the measurement.
        for k in [8, 9].repeat(20) {
            e.observe(&config, k, PACKET_NS, spread(1));
        }
        assert!(!e.escalated());
        assert_eq!(e.support(&config, 6.5, PACKET_NS), 8);
        // And no noise at all asks for nothing, whatever was measured before.
        for _ in 0..25 {
            e.observe(&config, 8, PACKET_NS, spread(1));
        }
        assert!(e.escalated());
        assert_eq!(e.support(&config, 0.0, PACKET_NS), 0);
    }
}
