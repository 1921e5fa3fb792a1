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
//!
//! One token may arrive out of order: an action the segmenter read only after it had emitted
//! the NULL that follows it (a path that waited for the window's home,
//! [`crate::segmenter::SegmentToken::late`]). [`FrameParser::push_late`] puts it back between
//! the two NULLs it belongs between, as if it had arrived in order; anywhere else it
//! invalidates what is held (it cannot be placed, so no frame may span it).

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
    /// Stamp of the last token pushed, when it was a NULL.
    last_null_ns: Option<u64>,
    /// The last two tokens pushed were NULLs: what was held between them, and both stamps.
    gap: Option<NullGap>,
}

/// Where an action read late belongs: between two consecutive NULLs.
#[derive(Debug, Clone)]
struct NullGap {
    held_after_first: Vec<(Token, u64)>,
    first_ns: u64,
    second_ns: u64,
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
        self.last_null_ns = None;
        self.gap = None;
    }

    /// Feeds one token as the segmenter confirmed it: in order, or late ([`Self::push_late`]).
    pub fn push_segment(
        &mut self,
        token: &crate::segmenter::SegmentToken,
    ) -> Option<ReleasedFrame> {
        if token.late {
            self.push_late(token.token, token.stamp_ns)
        } else {
            self.push(token.token, token.stamp_ns)
        }
    }

    /// Feeds an action read late: it belongs between the last two tokens pushed, which must be
    /// NULLs stamped before it (the first) and not before it (the second). Placed there, the
    /// frame is parsed as if it had arrived in order, and the second NULL may release it.
    /// Anywhere else the action cannot be placed and everything held is dropped.
    pub fn push_late(&mut self, token: Token, stamp_ns: u64) -> Option<ReleasedFrame> {
        let gap = self
            .gap
            .take()
            .filter(|g| g.first_ns < stamp_ns && stamp_ns <= g.second_ns);
        let Some(gap) = gap else {
            self.interrupt();
            return None;
        };
        self.held = gap.held_after_first;
        self.last_null_ns = Some(gap.first_ns);
        let released = self.push(token, stamp_ns);
        self.push(Token::Null, gap.second_ns).or(released)
    }

    /// Feeds one confirmed token; returns the frame it completes, if any.
    pub fn push(&mut self, token: Token, stamp_ns: u64) -> Option<ReleasedFrame> {
        self.gap = match (token, self.last_null_ns) {
            (Token::Null, Some(first_ns)) if first_ns <= stamp_ns => Some(NullGap {
                held_after_first: self.held.clone(),
                first_ns,
                second_ns: stamp_ns,
            }),
            _ => None,
        };
        self.last_null_ns = (token == Token::Null).then_some(stamp_ns);
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
    fn a_late_action_is_placed_only_between_two_nulls_before_it() {
        let f = frame_tokens(0b101101);
        // START read late: the frame is released by its final NULL as if in order.
        let mut p = FrameParser::new();
        p.push(f[0], 0);
        p.push(f[2], 20);
        assert_eq!(p.push_late(Token::Start, 20), None);
        assert_eq!(p.progress(), 3);
        let released: Vec<_> = (3..17)
            .filter_map(|i| p.push(f[i], 10 * i as u64))
            .collect();
        assert_eq!(released.len(), 1);
        assert_eq!(released[0].payload, 0b101101);
        assert_eq!(released[0].token_stamps_ns[..3], [0, 20, 20]);
        // END read late releases the frame at once, stamped by the NULL after it.
        let mut p = FrameParser::new();
        feed(&mut p, &f[..15]);
        assert_eq!(p.push(Token::Null, 16_000), None);
        let end = p
            .push_late(Token::End, 16_000)
            .expect("the late END completes the frame");
        assert_eq!(end.final_null_ns(), 16_000);
        // Not after two NULLs, or stamped outside their span: nothing held survives.
        for (prefix, stamp_ns) in [(&f[..3], 2_000), (&f[..4], 3_000), (&f[..5], 1_000)] {
            let mut p = FrameParser::new();
            feed(&mut p, prefix);
            p.push(Token::Null, 9_000);
            assert_eq!(p.push_late(Token::Bit1, stamp_ns), None);
            assert_eq!(p.progress(), 0, "{prefix:?} at {stamp_ns}");
        }
        // Only one action fits a gap.
        let mut p = FrameParser::new();
        p.push(Token::Null, 0);
        p.push(Token::Null, 10);
        p.push_late(Token::Start, 10);
        assert_eq!(p.push_late(Token::Bit0, 10), None);
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

        /// An action (or a rejection) pushed late, after the NULL that follows it, releases
        /// exactly the frames, with the same stamps, that it releases in order.
        #[test]
        fn an_action_pushed_late_parses_as_in_order(seq in sequence_strategy(), pick in any::<prop::sample::Index>()) {
            let gaps: Vec<usize> = (1..seq.len().saturating_sub(1))
                .filter(|&k| seq[k - 1] == Token::Null && seq[k] != Token::Null && seq[k + 1] == Token::Null)
                .collect();
            prop_assume!(!gaps.is_empty());
            let k = gaps[pick.index(gaps.len())];
            let stamp = |j: usize| 10 * j as u64;
            let mut in_order = FrameParser::new();
            let want: Vec<ReleasedFrame> =
                seq.iter().enumerate().filter_map(|(j, &t)| in_order.push(t, stamp(j))).collect();
            let mut late = FrameParser::new();
            let mut got = Vec::new();
            for (j, &t) in seq.iter().enumerate() {
                if j == k {
                    continue;
                }
                got.extend(late.push(t, stamp(j)));
                if j == k + 1 {
                    got.extend(late.push_late(seq[k], stamp(k)));
                }
            }
            prop_assert_eq!(got, want, "action {:?} at {} of {:?}", seq[k], k, seq);
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
