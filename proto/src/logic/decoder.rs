//! Segmenter + frame parser: from receiver samples to tokens and released frames.

use crate::{FrameParser, ReleasedFrame};

use crate::segmenter::{Sample, SegmentToken, Segmenter, SegmenterConfig, SegmenterError};

/// What one decoder step produced.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DecodeStep {
    /// Tokens confirmed at this step, in order.
    pub tokens: Vec<SegmentToken>,
    /// Frames released at this step (at most one in practice).
    pub frames: Vec<ReleasedFrame>,
}

/// One observer's decoding chain below the receiver front end: the shared [`Segmenter`]
/// feeding the 17-token [`FrameParser`].
#[derive(Debug, Clone)]
pub struct Decoder {
    segmenter: Segmenter,
    parser: FrameParser,
}

impl Decoder {
    pub fn new(config: SegmenterConfig) -> Result<Self, SegmenterError> {
        Ok(Self {
            segmenter: Segmenter::new(config)?,
            parser: FrameParser::new(),
        })
    }

    pub fn segmenter(&self) -> &Segmenter {
        &self.segmenter
    }

    pub fn parser(&self) -> &FrameParser {
        &self.parser
    }

    /// Parses frames carrying `check` from now on (a session's protocol, set before its first
    /// sample); any incomplete frame is dropped.
    pub fn set_frame_check(&mut self, check: crate::FrameCheck) {
        self.parser = FrameParser::with_check(check);
    }

    /// Consumes one receiver sample.
    pub fn push(&mut self, sample: Sample) -> Result<DecodeStep, SegmenterError> {
        let tokens = self.segmenter.push(sample)?;
        Ok(self.parse(tokens))
    }

    /// How far the observer's airframe has turned from its home attitude, undone from the next
    /// sample on ([`Segmenter::set_ego_rotation`]).
    pub fn set_ego_rotation(&mut self, ego: Option<crate::stabilise::EgoRotation>) {
        self.segmenter.set_ego_rotation(ego);
    }

    /// Reports missing input or a fault at `stamp_ns`; drops any incomplete frame.
    pub fn interrupt(&mut self, stamp_ns: u64) -> Result<DecodeStep, SegmenterError> {
        let token = self.segmenter.interrupt(stamp_ns)?;
        // Even when continuity was already broken (no new token), nothing may survive.
        self.parser.interrupt();
        Ok(self.parse(token.into_iter().collect()))
    }

    /// Starts afresh (e.g. a round reset): forgets rest, path and incomplete frame, emitting
    /// nothing. The next sample is treated as the first one.
    pub fn reset(&mut self) {
        self.segmenter.reset();
        self.parser.interrupt();
    }

    fn parse(&mut self, tokens: Vec<SegmentToken>) -> DecodeStep {
        let frames = tokens
            .iter()
            .filter_map(|t| self.parser.push_segment(t))
            .collect();
        DecodeStep { tokens, frames }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::frame_tokens;
    use crate::segmenter::tests::{CENTRE, S, Script};

    /// A whole frame drawn in the image: hovers of 5 s, symbols of 4 s at 90 px.
    fn drawn_frame(sc: &mut Script, payload: u8) {
        for token in frame_tokens(payload) {
            match token.action() {
                Some(a) => sc.draw(a, CENTRE, 90.0, 4 * S),
                None => sc.hover(CENTRE, 5 * S),
            };
        }
    }

    fn decode(d: &mut Decoder, samples: &[crate::Sample]) -> DecodeStep {
        let mut all = DecodeStep::default();
        for &s in samples {
            let step = d.push(s).unwrap();
            all.tokens.extend(step.tokens);
            all.frames.extend(step.frames);
        }
        all
    }

    #[test]
    fn a_drawn_frame_is_released_by_its_final_null_with_its_stamps() {
        let mut sc = Script::new(0);
        drawn_frame(&mut sc, 0b011010);
        let mut d = Decoder::new(SegmenterConfig::rgb()).unwrap();
        let out = decode(&mut d, &sc.samples);
        let got: Vec<_> = out.tokens.iter().map(|t| t.token).collect();
        assert_eq!(got, frame_tokens(0b011010).to_vec());
        assert_eq!(out.frames.len(), 1);
        let f = &out.frames[0];
        assert_eq!(f.payload, 0b011010);
        let stamps: Vec<_> = out.tokens.iter().map(|t| t.stamp_ns).collect();
        assert_eq!(f.token_stamps_ns, stamps);
        assert_eq!(f.check(), Ok(()));
    }

    #[test]
    fn an_interrupt_mid_frame_or_a_reset_prevents_release() {
        let mut sc = Script::new(0);
        drawn_frame(&mut sc, 0b100111);
        let cut = sc.samples.len() / 2;
        for reset in [false, true] {
            let mut d = Decoder::new(SegmenterConfig::events()).unwrap();
            let mut out = decode(&mut d, &sc.samples[..cut]);
            assert!(d.parser().progress() > 0, "a frame is in progress");
            if reset {
                d.reset();
                assert_eq!(d.parser().progress(), 0);
            } else {
                let step = d.interrupt(sc.samples[cut - 1].stamp_ns).unwrap();
                assert_eq!(step.tokens.len(), 1);
                out.tokens.extend(step.tokens);
            }
            out.frames.extend(decode(&mut d, &sc.samples[cut..]).frames);
            assert!(out.frames.is_empty(), "reset={reset}");
        }
        // Control: the same stream without the cut is released.
        let mut d = Decoder::new(SegmenterConfig::events()).unwrap();
        assert_eq!(decode(&mut d, &sc.samples).frames.len(), 1);
    }

    #[test]
    fn two_drawn_frames_share_the_hover_between_them() {
        let mut sc = Script::new(0);
        drawn_frame(&mut sc, 0b011010);
        // The second frame's first NULL is the first frame's final NULL: no extra hover.
        for token in &frame_tokens(0b100111)[1..] {
            match token.action() {
                Some(a) => sc.draw(a, CENTRE, 90.0, 4 * S),
                None => sc.hover(CENTRE, 5 * S),
            };
        }
        let mut d = Decoder::new(SegmenterConfig::rgb()).unwrap();
        let out = decode(&mut d, &sc.samples);
        let payloads: Vec<_> = out.frames.iter().map(|f| f.payload).collect();
        assert_eq!(payloads, vec![0b011010, 0b100111]);
        assert_eq!(out.frames[0].final_null_ns(), out.frames[1].first_null_ns());
        assert!(out.tokens.iter().all(|t| t.token != crate::Token::Unknown));
    }
}
