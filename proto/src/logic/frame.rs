//! The 17-token frame parser: `NULL START NULL b1 NULL b2 … b6 NULL END NULL`.
//!
//! The parser is a matcher for one fixed pattern whose six bit positions are wildcards over
//! `{Bit0, Bit1}`. Its state is always the **longest suffix of the tokens seen since the last
//! invalidation that is a prefix of a valid frame**. That one rule fixes every edge case:
//!
//! - only the 17th matching token, the final NULL, releases a frame; END alone never does;
//! - repeated NULLs while idle just re-arm (a NULL from acquisition may precede START);
//! - a wrong token mid-frame abandons the incomplete frame; if the wrong token is a NULL it is
//!   kept as the possible first NULL of a new frame, and a START right after a NULL (even one
//!   that belonged to the abandoned frame) begins a new frame `NULL START`;
//! - the releasing NULL is kept as the possible first NULL of the next frame, so back-to-back
//!   frames need only one hover between them;
//! - `Unknown`, an explicit [`FrameParser::interrupt`], or a token stamped earlier than its
//!   predecessor invalidates everything held.
//!
//! Consequently a frame is released at a token iff the last 17 tokens since the last
//! invalidation form a valid frame.

use serde::{Deserialize, Serialize};

use crate::token::Token;

/// Tokens in a complete frame.
pub const FRAME_TOKENS: usize = 17;
/// Payload bits in a frame.
pub const FRAME_BITS: usize = 6;

/// What a frame position accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Slot {
    Null,
    Start,
    Bit,
    End,
}

const PATTERN: [Slot; FRAME_TOKENS] = [
    Slot::Null,
    Slot::Start,
    Slot::Null,
    Slot::Bit,
    Slot::Null,
    Slot::Bit,
    Slot::Null,
    Slot::Bit,
    Slot::Null,
    Slot::Bit,
    Slot::Null,
    Slot::Bit,
    Slot::Null,
    Slot::Bit,
    Slot::Null,
    Slot::End,
    Slot::Null,
];

fn fits(slot: Slot, token: Token) -> bool {
    matches!(
        (slot, token),
        (Slot::Null, Token::Null)
            | (Slot::Start, Token::Start)
            | (Slot::Bit, Token::Bit0 | Token::Bit1)
            | (Slot::End, Token::End)
    )
}

/// True when `tokens` is a prefix (possibly all) of a valid frame.
pub fn is_frame_prefix(tokens: &[Token]) -> bool {
    tokens.len() <= FRAME_TOKENS && tokens.iter().zip(PATTERN).all(|(&t, s)| fits(s, t))
}

/// True when `tokens` is exactly one valid frame.
pub fn is_valid_frame(tokens: &[Token]) -> bool {
    tokens.len() == FRAME_TOKENS && is_frame_prefix(tokens)
}

/// The 17 tokens of the frame carrying `payload` (low six bits, b1 = most significant).
pub fn frame_tokens(payload: u8) -> [Token; FRAME_TOKENS] {
    let mut out = [Token::Null; FRAME_TOKENS];
    out[1] = Token::Start;
    for k in 0..FRAME_BITS {
        out[3 + 2 * k] = if bit_of(payload, k) {
            Token::Bit1
        } else {
            Token::Bit0
        };
    }
    out[15] = Token::End;
    out
}

/// Bit `k` (0-based, transmission order) of a 6-bit payload.
fn bit_of(payload: u8, k: usize) -> bool {
    payload >> (FRAME_BITS - 1 - k) & 1 == 1
}

/// A complete frame, released by its final NULL.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ReleasedFrame {
    /// The six bits `b1 … b6` as a number, b1 most significant (so `011010` = 0b011010).
    pub payload: u8,
    /// Confirmation time of each of the 17 tokens, sim nanoseconds, in frame order.
    pub token_stamps_ns: Vec<u64>,
}

impl ReleasedFrame {
    /// The bits in transmission order.
    pub fn bits(&self) -> [bool; FRAME_BITS] {
        std::array::from_fn(|k| bit_of(self.payload, k))
    }

    /// Time of the releasing (final) NULL.
    pub fn final_null_ns(&self) -> u64 {
        self.token_stamps_ns.last().copied().unwrap_or(0)
    }

    /// Time of the first NULL.
    pub fn first_null_ns(&self) -> u64 {
        self.token_stamps_ns.first().copied().unwrap_or(0)
    }

    /// Consistency of a frame received off the wire.
    pub fn check(&self) -> Result<(), String> {
        if self.payload >= 1 << FRAME_BITS {
            return Err(format!(
                "frame payload {} does not fit in {FRAME_BITS} bits",
                self.payload
            ));
        }
        if self.token_stamps_ns.len() != FRAME_TOKENS {
            return Err(format!(
                "frame has {} token stamps, want {FRAME_TOKENS}",
                self.token_stamps_ns.len()
            ));
        }
        if self.token_stamps_ns.windows(2).any(|w| w[1] < w[0]) {
            return Err("frame token stamps go backwards".into());
        }
        Ok(())
    }
}

/// Incremental frame parser for one observer.
#[derive(Debug, Clone, Default)]
pub struct FrameParser {
    /// Longest valid frame prefix that is a suffix of the input, with token stamps.
    held: Vec<(Token, u64)>,
}

impl FrameParser {
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of tokens of the incomplete frame currently held (0 when idle).
    pub fn progress(&self) -> usize {
        self.held.len()
    }

    /// The tokens currently held, oldest first.
    pub fn held_tokens(&self) -> impl Iterator<Item = Token> + '_ {
        self.held.iter().map(|&(t, _)| t)
    }

    /// Drops any incomplete frame (input gap, lost tracking, round reset).
    pub fn interrupt(&mut self) {
        self.held.clear();
    }

    /// Feeds one confirmed token; returns the frame it completes, if any.
    pub fn push(&mut self, token: Token, stamp_ns: u64) -> Option<ReleasedFrame> {
        if token == Token::Unknown {
            self.held.clear();
            return None;
        }
        if self.held.last().is_some_and(|&(_, t)| stamp_ns < t) {
            // Time ran backwards: nothing held can share a frame with this token.
            self.held.clear();
        }
        self.held.push((token, stamp_ns));
        // Shortest drop that leaves a valid prefix; always ends at most at the empty suffix.
        let keep_from = (0..=self.held.len())
            .find(|&i| is_frame_prefix(&self.held_tokens().skip(i).collect::<Vec<_>>()))
            .unwrap_or(self.held.len());
        self.held.drain(..keep_from);
        if self.held.len() < FRAME_TOKENS {
            return None;
        }
        let payload = (0..FRAME_BITS).fold(0u8, |acc, k| {
            (acc << 1) | u8::from(self.held[3 + 2 * k].0 == Token::Bit1)
        });
        let frame = ReleasedFrame {
            payload,
            token_stamps_ns: self.held.iter().map(|&(_, t)| t).collect(),
        };
        // The releasing NULL may open the next frame.
        self.held.drain(..FRAME_TOKENS - 1);
        Some(frame)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn feed(p: &mut FrameParser, tokens: &[Token]) -> Vec<(usize, ReleasedFrame)> {
        tokens
            .iter()
            .enumerate()
            .filter_map(|(i, &t)| p.push(t, 1000 * i as u64).map(|f| (i, f)))
            .collect()
    }

    fn token_strategy() -> impl Strategy<Value = Token> {
        // Weighted towards the frame's own tokens so that valid frames actually occur.
        prop_oneof![
            8 => Just(Token::Null),
            2 => Just(Token::Start),
            3 => Just(Token::Bit0),
            3 => Just(Token::Bit1),
            2 => Just(Token::End),
            1 => Just(Token::Unknown),
        ]
    }

    /// A random sequence made of random tokens and embedded (possibly mutated) frames.
    fn sequence_strategy() -> impl Strategy<Value = Vec<Token>> {
        let chunk = prop_oneof![
            prop::collection::vec(token_strategy(), 0..6),
            (0u8..64).prop_map(|p| frame_tokens(p).to_vec()),
            // A frame that relies on the preceding NULL as its first NULL.
            (0u8..64).prop_map(|p| frame_tokens(p)[1..].to_vec()),
            ((0u8..64), 0usize..17, token_strategy()).prop_map(|(p, i, t)| {
                let mut f = frame_tokens(p).to_vec();
                f[i] = t;
                f
            }),
        ];
        prop::collection::vec(chunk, 0..8).prop_map(|c| c.concat())
    }

    #[test]
    fn paper_payload_is_released_by_the_final_null_only() {
        let mut p = FrameParser::new();
        let tokens = frame_tokens(0b011010);
        for (i, &t) in tokens.iter().enumerate().take(16) {
            assert_eq!(p.push(t, i as u64), None, "released early at token {i}");
        }
        assert_eq!(p.progress(), 16, "END is held, not released");
        let f = p.push(Token::Null, 16).expect("final NULL releases");
        assert_eq!(f.payload, 0b011010);
        assert_eq!(f.bits(), [false, true, true, false, true, false]);
        assert_eq!(f.token_stamps_ns, (0..17).collect::<Vec<u64>>());
        assert_eq!(f.final_null_ns(), 16);
        assert_eq!(f.check(), Ok(()));
    }

    #[test]
    fn acquisition_nulls_before_start_just_rearm() {
        let mut p = FrameParser::new();
        let mut seq = vec![Token::Null; 5];
        seq.extend(frame_tokens(0b100111));
        let released = feed(&mut p, &seq);
        assert_eq!(released.len(), 1);
        let (i, f) = &released[0];
        assert_eq!(*i, seq.len() - 1);
        assert_eq!(f.payload, 0b100111);
        // The frame's first NULL is the one right before START.
        assert_eq!(f.first_null_ns(), 5000);
    }

    #[test]
    fn back_to_back_frames_may_share_the_hover_between_them() {
        let mut p = FrameParser::new();
        let mut seq = frame_tokens(0b011010).to_vec();
        seq.extend(&frame_tokens(0b100111)[1..]);
        let released: Vec<u8> = feed(&mut p, &seq)
            .into_iter()
            .map(|(_, f)| f.payload)
            .collect();
        assert_eq!(released, vec![0b011010, 0b100111]);
    }

    #[test]
    fn wrong_token_mid_frame_resets_and_start_after_null_restarts() {
        let mut p = FrameParser::new();
        let f = frame_tokens(0b000000);
        feed(&mut p, &f[..5]); // NULL START NULL b1 NULL
        assert_eq!(p.push(Token::Start, 10_000), None);
        assert_eq!(
            p.held_tokens().collect::<Vec<_>>(),
            vec![Token::Null, Token::Start]
        );
        assert_eq!(p.push(Token::Null, 11_000), None);
        assert_eq!(p.push(Token::Null, 12_000), None, "two NULLs in a row");
        assert_eq!(p.held_tokens().collect::<Vec<_>>(), vec![Token::Null]);
        assert_eq!(p.push(Token::End, 13_000), None);
        assert_eq!(p.progress(), 0);
    }

    #[test]
    fn unknown_interrupt_and_backwards_time_invalidate() {
        let f = frame_tokens(0b010000);
        let mut p = FrameParser::new();
        feed(&mut p, &f[..9]);
        p.interrupt();
        assert_eq!(p.progress(), 0);
        feed(&mut p, &f[..9]);
        assert_eq!(p.push(Token::Unknown, 9_000), None);
        assert_eq!(p.progress(), 0);
        feed(&mut p, &f[..9]);
        assert_eq!(p.push(f[9], 1), None, "stamp earlier than the held tokens");
        assert_eq!(p.progress(), 0);
    }

    #[test]
    fn end_alone_never_releases() {
        let mut p = FrameParser::new();
        let seq = [
            Token::Null,
            Token::End,
            Token::Null,
            Token::End,
            Token::Null,
        ];
        assert!(feed(&mut p, &seq).is_empty());
    }

    #[test]
    fn wire_check_rejects_bad_frames() {
        let ok = ReleasedFrame {
            payload: 5,
            token_stamps_ns: (0..17).collect(),
        };
        assert!(ok.check().is_ok());
        assert!(
            ReleasedFrame {
                payload: 64,
                ..ok.clone()
            }
            .check()
            .is_err()
        );
        assert!(
            ReleasedFrame {
                token_stamps_ns: (0..16).collect(),
                ..ok.clone()
            }
            .check()
            .is_err()
        );
        let mut back = ok.clone();
        back.token_stamps_ns.swap(3, 4);
        assert!(back.check().is_err());
    }

    proptest! {
        /// Releases happen exactly at the tokens that end a valid 17-token window of the input
        /// (an `Unknown` breaks every window through it), and carry that window's bits and stamps.
        #[test]
        fn releases_iff_the_last_17_tokens_are_a_valid_frame(seq in sequence_strategy()) {
            let mut p = FrameParser::new();
            for (i, &t) in seq.iter().enumerate() {
                let got = p.push(t, 10 * i as u64);
                let window_ok = i + 1 >= FRAME_TOKENS && is_valid_frame(&seq[i + 1 - FRAME_TOKENS..=i]);
                prop_assert_eq!(got.is_some(), window_ok, "at token {} of {:?}", i, seq);
                if let Some(f) = got {
                    let w = &seq[i + 1 - FRAME_TOKENS..=i];
                    let tokens = frame_tokens(f.payload);
                    prop_assert_eq!(tokens.as_slice(), w);
                    let want: Vec<u64> = (i + 1 - FRAME_TOKENS..=i).map(|j| 10 * j as u64).collect();
                    prop_assert_eq!(f.token_stamps_ns, want);
                }
            }
        }

        #[test]
        fn a_valid_frame_is_released_with_its_payload(payload in 0u8..64) {
            let mut p = FrameParser::new();
            let released = feed(&mut p, &frame_tokens(payload));
            prop_assert_eq!(released.len(), 1);
            prop_assert_eq!(released[0].0, FRAME_TOKENS - 1);
            prop_assert_eq!(released[0].1.payload, payload);
        }

        #[test]
        fn any_single_drop_prevents_release(payload in 0u8..64, i in 0usize..17) {
            let mut seq = frame_tokens(payload).to_vec();
            seq.remove(i);
            prop_assert!(feed(&mut FrameParser::new(), &seq).is_empty());
        }

        /// Duplicating a token inside the frame breaks it. (A duplicated first NULL is just an
        /// extra acquisition NULL, and a duplicated final NULL comes after the release.)
        #[test]
        fn any_single_inner_duplicate_prevents_release(payload in 0u8..64, i in 1usize..16) {
            let mut seq = frame_tokens(payload).to_vec();
            seq.insert(i, seq[i]);
            prop_assert!(feed(&mut FrameParser::new(), &seq).is_empty());
        }

        #[test]
        fn any_single_unknown_prevents_release(payload in 0u8..64, i in 0usize..17, replace in any::<bool>()) {
            let mut seq = frame_tokens(payload).to_vec();
            if replace {
                seq[i] = Token::Unknown;
            } else {
                // Inserting before the first NULL would leave the frame itself intact.
                seq.insert(i.max(1), Token::Unknown);
            }
            prop_assert!(feed(&mut FrameParser::new(), &seq).is_empty());
        }

        #[test]
        fn an_interrupt_anywhere_inside_prevents_release(payload in 0u8..64, i in 1usize..17) {
            let seq = frame_tokens(payload);
            let mut p = FrameParser::new();
            let mut released = feed(&mut p, &seq[..i]);
            p.interrupt();
            released.extend(seq[i..].iter().filter_map(|&t| p.push(t, 1_000_000).map(|f| (0, f))));
            prop_assert!(released.is_empty());
        }
    }
}
