//! What one camera delivered (`camera/<o>/report`), published once as it ends: the evidence of
//! determinism (a running digest of every packet it published) and the routes its renders took.
//! The launcher builds `summary.json`'s `sensor_digests` and `camera_renders` from these, on
//! whichever host the camera ran.

use serde::{Deserialize, Serialize};

use crate::codec::Validate;
use crate::keys::ObserverId;
use crate::modality::RenderPath;

/// One camera's account of its run.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct CameraReport {
    pub observer: ObserverId,
    /// Packets (RGB frames or event packets) it published.
    pub packets: u64,
    /// Packets a throttle fault dropped before publication.
    pub dropped: u64,
    /// Running digest of every published packet's encoding, in order.
    pub digest: u64,
    /// The render path it was started with.
    pub render: RenderPath,
    /// Renders that rasterised and read back the whole frame.
    pub full_renders: u64,
    /// Renders of only the rectangle the moved bodies could cover.
    pub damage_renders: u64,
    /// Render instants skipped because nothing the camera sees changed.
    pub skipped_renders: u64,
    /// Pixels drawn and read back by damage renders.
    pub damage_px: u64,
    /// Whether damage renders rasterised only their rectangle.
    pub scissored: bool,
}

impl CameraReport {
    /// The digest as `summary.json` and the golden files hold it
    /// (`packets=… dropped=… digest=<16 hex digits>`).
    pub fn digest_line(&self) -> String {
        format!(
            "packets={} dropped={} digest={:016x}",
            self.packets, self.dropped, self.digest
        )
    }
}

/// Folds `bytes` into the running digest `h` (8-byte words, multiply–rotate): cheap enough for
/// every RGB frame, and any changed byte changes it. A camera folds the encoding of every packet
/// it publishes, in order, into [`CameraReport::digest`]; a recorder that keeps an event
/// camera's input instead of its packets folds the packets it received the same way, so a
/// replay that regenerates them can show it made the same bytes.
pub fn digest(mut h: u64, bytes: &[u8]) -> u64 {
    const K: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut chunks = bytes.chunks_exact(8);
    for c in &mut chunks {
        let w = u64::from_le_bytes(c.try_into().expect("8-byte chunk"));
        h = (h ^ w).wrapping_mul(K).rotate_left(29);
    }
    for &b in chunks.remainder() {
        h = (h ^ u64::from(b)).wrapping_mul(K).rotate_left(29);
    }
    (h ^ bytes.len() as u64).wrapping_mul(K)
}

impl Validate for CameraReport {
    fn validate(&self) -> Result<(), String> {
        let renders = self
            .full_renders
            .checked_add(self.damage_renders)
            .and_then(|r| r.checked_add(self.skipped_renders));
        if renders.is_none() {
            return Err("camera report render counts overflow".into());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_digest_sees_every_byte_and_the_length() {
        let a = vec![7u8; 1001];
        let base = digest(0, &a);
        assert_eq!(base, digest(0, &a.clone()));
        for i in [0, 500, 999, 1000] {
            let mut b = a.clone();
            b[i] ^= 1;
            assert_ne!(digest(0, &b), base, "byte {i}");
        }
        assert_ne!(digest(0, &a[..1000]), base);
        assert_ne!(digest(digest(0, &a), &a), base);
    }

    #[test]
    fn the_digest_line_is_the_golden_format_and_the_report_round_trips() {
        let r = CameraReport {
            observer: ObserverId::new("O2").unwrap(),
            packets: 3200,
            dropped: 0,
            digest: 0x00cb_0722_0227_74b4,
            render: RenderPath::Damage,
            full_renders: 3,
            damage_renders: 10,
            skipped_renders: 5,
            damage_px: 99,
            scissored: true,
        };
        assert_eq!(
            r.digest_line(),
            "packets=3200 dropped=0 digest=00cb0722022774b4"
        );
        assert_eq!(
            crate::decode::<CameraReport>(&crate::encode(&r)).unwrap(),
            r
        );
        let mut bad = r;
        bad.full_renders = u64::MAX;
        assert!(bad.validate().is_err());
    }
}
