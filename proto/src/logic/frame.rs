//! The 17-token frame parser: `NULL START NULL b1 NULL b2 … b6 NULL END NULL`.
//!
//! A session may agree on a [`FrameCheck`]: then the six bits are followed by one (parity) or
//! three (CRC-3) check bits, each flown as a bit symbol between NULLs, before `END`. A frame
//! whose check bits disagree with its payload is counted ([`FrameParser::check_failures`]) and
//! never released. Everything below holds with "valid frame" meaning "matches the pattern and
//! its check".
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

/// Tokens in a complete frame without a check (the paper's frame).
pub const FRAME_TOKENS: usize = 17;
/// Payload bits in a frame.
pub const FRAME_BITS: usize = 6;
/// Tokens in the longest frame any [`FrameCheck`] gives.
pub const MAX_FRAME_TOKENS: usize = FRAME_TOKENS + 2 * 3;

/// The check a session's frames carry after their six payload bits.
///
/// A one-shot six-bit frame has none (the paper's protocol): a `Bit0` read as `Bit1` releases
/// another valid offer. With a check, the performer flies the remainder of the payload divided
/// by the check's generator polynomial, most significant bit first, and a receiver releases
/// only frames whose remainder agrees. Parity (`x + 1`) catches any odd number of flipped bits;
/// CRC-3 (`x³ + x + 1`) catches every single and double flip within the nine bits except two
/// flips exactly seven apart, at the cost of three more symbols (≈ 35 s a frame).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum FrameCheck {
    /// No check (the paper's frame, 17 tokens).
    #[default]
    None,
    /// One even-parity bit (19 tokens).
    Parity,
    /// Three CRC bits, generator `x³ + x + 1` (23 tokens).
    Crc3,
}

impl FrameCheck {
    /// Every check, in the order of their names' sort.
    pub const ALL: [FrameCheck; 3] = [FrameCheck::Crc3, FrameCheck::None, FrameCheck::Parity];

    /// The name used in case files and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            FrameCheck::None => "none",
            FrameCheck::Parity => "parity",
            FrameCheck::Crc3 => "crc3",
        }
    }

    /// Check bits flown after the payload.
    pub fn bits(self) -> usize {
        match self {
            FrameCheck::None => 0,
            FrameCheck::Parity => 1,
            FrameCheck::Crc3 => 3,
        }
    }

    /// Tokens in one complete frame.
    pub fn frame_tokens(self) -> usize {
        FRAME_TOKENS + 2 * self.bits()
    }

    /// The check whose frames have `tokens` tokens, if any.
    pub fn for_frame_tokens(tokens: usize) -> Option<FrameCheck> {
        Self::ALL.into_iter().find(|c| c.frame_tokens() == tokens)
    }

    /// The check bits of a 6-bit `payload`, as a number (first flown = most significant).
    pub fn remainder(self, payload: u8) -> u8 {
        // Generator polynomials with their leading term, as bit masks.
        let generator: u16 = match self {
            FrameCheck::None => return 0,
            FrameCheck::Parity => 0b11,
            FrameCheck::Crc3 => 0b1011,
        };
        let n = self.bits();
        let mut r = u16::from(payload & 0x3f) << n;
        for i in (n..FRAME_BITS + n).rev() {
            if r >> i & 1 == 1 {
                r ^= generator << (i - n);
            }
        }
        // Below 2^n after the division, so it fits in a byte.
        (r & ((1 << n) - 1)) as u8
    }

    /// The tokens of the frame carrying `payload` (low six bits, b1 = most significant).
    pub fn tokens_of(self, payload: u8) -> Vec<Token> {
        let bits = self.frame_bits(payload);
        let mut out = vec![Token::Null; self.frame_tokens()];
        out[1] = Token::Start;
        for (k, bit) in bits.iter().enumerate() {
            out[3 + 2 * k] = if *bit { Token::Bit1 } else { Token::Bit0 };
        }
        let last = out.len() - 1;
        out[last - 1] = Token::End;
        out
    }

    /// The bits flown for `payload`: its six bits, then the check bits.
    pub fn frame_bits(self, payload: u8) -> Vec<bool> {
        let n = self.bits();
        let check = self.remainder(payload);
        (0..FRAME_BITS)
            .map(|k| bit_of(payload, k))
            .chain((0..n).map(|k| check >> (n - 1 - k) & 1 == 1))
            .collect()
    }
}

impl std::fmt::Display for FrameCheck {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::str::FromStr for FrameCheck {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|c| c.as_str() == s)
            .ok_or_else(|| format!("frame_check = {s:?}: want one of crc3, none, parity"))
    }
}

/// What a frame position accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Slot {
    Null,
    Start,
    Bit,
    End,
}

/// What position `i` of a frame of `len` tokens accepts.
fn slot(i: usize, len: usize) -> Slot {
    match i {
        1 => Slot::Start,
        _ if i + 2 == len => Slot::End,
        _ if i.is_multiple_of(2) => Slot::Null,
        _ => Slot::Bit,
    }
}

fn fits(slot: Slot, token: Token) -> bool {
    matches!(
        (slot, token),
        (Slot::Null, Token::Null)
            | (Slot::Start, Token::Start)
            | (Slot::Bit, Token::Bit0 | Token::Bit1)
            | (Slot::End, Token::End)
    )
}

/// True when `tokens` is a prefix (possibly all) of a paper frame's pattern.
pub fn is_frame_prefix(tokens: &[Token]) -> bool {
    is_prefix_of(FrameCheck::None, tokens)
}

/// True when `tokens` is a prefix (possibly all) of the pattern of a frame with `check`
/// (the check itself is judged only on a whole frame).
pub fn is_prefix_of(check: FrameCheck, tokens: &[Token]) -> bool {
    let len = check.frame_tokens();
    tokens.len() <= len
        && tokens
            .iter()
            .enumerate()
            .all(|(i, &t)| fits(slot(i, len), t))
}

/// True when `tokens` is exactly one valid paper frame.
pub fn is_valid_frame(tokens: &[Token]) -> bool {
    tokens.len() == FRAME_TOKENS && is_frame_prefix(tokens)
}

/// True when `tokens` is exactly one frame with `check` whose check bits agree.
pub fn is_valid_frame_of(check: FrameCheck, tokens: &[Token]) -> bool {
    tokens.len() == check.frame_tokens()
        && is_prefix_of(check, tokens)
        && check.tokens_of(payload_of(tokens)) == tokens
}

/// The payload of a frame-shaped token sequence (its first six bit slots).
fn payload_of(tokens: &[Token]) -> u8 {
    (0..FRAME_BITS).fold(0u8, |acc, k| {
        (acc << 1) | u8::from(tokens.get(3 + 2 * k) == Some(&Token::Bit1))
    })
}

/// The 17 tokens of the paper frame carrying `payload` (low six bits, b1 = most significant).
pub fn frame_tokens(payload: u8) -> [Token; FRAME_TOKENS] {
    let mut out = [Token::Null; FRAME_TOKENS];
    out.copy_from_slice(&FrameCheck::None.tokens_of(payload));
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
    /// Confirmation time of each token (17; 19 or 23 with a frame check), sim nanoseconds, in
    /// frame order.
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
        if FrameCheck::for_frame_tokens(self.token_stamps_ns.len()).is_none() {
            return Err(format!(
                "frame has {} token stamps, want {FRAME_TOKENS} (or 19, 23 with a check)",
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
    /// The check the session's frames carry.
    check: FrameCheck,
    /// Whole frames whose check bits disagreed with their payload.
    check_failures: u64,
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
    /// A parser of the paper's frames (no check).
    pub fn new() -> Self {
        Self::default()
    }

    /// A parser of frames carrying `check`.
    pub fn with_check(check: FrameCheck) -> Self {
        Self {
            check,
            ..Self::default()
        }
    }

    /// The check this parser expects.
    pub fn check(&self) -> FrameCheck {
        self.check
    }

    /// Whole frames refused because their check bits disagreed with their payload.
    pub fn check_failures(&self) -> u64 {
        self.check_failures
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
        let check = self.check;
        let keep_from = (0..=self.held.len())
            .find(|&i| is_prefix_of(check, &self.held_tokens().skip(i).collect::<Vec<_>>()))
            .unwrap_or(self.held.len());
        self.held.drain(..keep_from);
        let len = check.frame_tokens();
        if self.held.len() < len {
            return None;
        }
        let tokens: Vec<Token> = self.held_tokens().collect();
        let payload = payload_of(&tokens);
        let agrees = check.tokens_of(payload) == tokens;
        let frame = ReleasedFrame {
            payload,
            token_stamps_ns: self.held.iter().map(|&(_, t)| t).collect(),
        };
        // The final NULL may open the next frame, whether or not this one passed its check.
        self.held.drain(..len - 1);
        if !agrees {
            self.check_failures += 1;
            return None;
        }
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

    #[test]
    fn check_bits_are_the_remainder_of_the_generator() {
        for payload in 0u8..64 {
            assert_eq!(
                FrameCheck::Parity.remainder(payload),
                (payload.count_ones() % 2) as u8,
                "parity of {payload:06b}"
            );
            // Appending the remainder gives a multiple of the generator: dividing again leaves 0.
            let word = (u16::from(payload) << 3) | u16::from(FrameCheck::Crc3.remainder(payload));
            let mut r = word;
            for i in (3..9).rev() {
                if r >> i & 1 == 1 {
                    r ^= 0b1011 << (i - 3);
                }
            }
            assert_eq!(r, 0, "{payload:06b} with its CRC-3");
        }
        assert_eq!(FrameCheck::None.tokens_of(0b011010), frame_tokens(0b011010));
        assert_eq!(
            FrameCheck::Crc3.frame_bits(0b100000), // x⁸ mod (x³ + x + 1) = x
            [true, false, false, false, false, false, false, true, false]
        );
    }

    /// Flipping bits of a checked frame, as a receiver misreading a V would: which flips the
    /// check lets through.
    #[test]
    fn checks_catch_the_flips_they_promise() {
        let flipped = |check: FrameCheck, payload: u8, flips: &[usize]| {
            let mut tokens = check.tokens_of(payload);
            for &k in flips {
                let t = &mut tokens[3 + 2 * k];
                *t = if *t == Token::Bit1 {
                    Token::Bit0
                } else {
                    Token::Bit1
                };
            }
            tokens
        };
        for payload in 0u8..64 {
            for check in [FrameCheck::Parity, FrameCheck::Crc3] {
                let n = 6 + check.bits();
                assert!(is_valid_frame_of(check, &check.tokens_of(payload)));
                for a in 0..n {
                    assert!(!is_valid_frame_of(check, &flipped(check, payload, &[a])));
                    for b in a + 1..n {
                        let caught = !is_valid_frame_of(check, &flipped(check, payload, &[a, b]));
                        let promised = check == FrameCheck::Crc3 && b - a != 7;
                        assert!(caught || !promised, "{check} {payload:06b} flips {a},{b}");
                        if check == FrameCheck::Parity {
                            assert!(!caught, "parity cannot see two flips");
                        }
                    }
                }
            }
            // Without a check every flip is another valid frame.
            assert!(is_valid_frame_of(
                FrameCheck::None,
                &flipped(FrameCheck::None, payload, &[2])
            ));
        }
    }

    #[test]
    fn a_frame_failing_its_check_is_counted_and_its_final_null_reopens() {
        let check = FrameCheck::Crc3;
        let mut p = FrameParser::with_check(check);
        let mut bad = check.tokens_of(0b010000);
        bad[3 + 2 * 2] = Token::Bit1; // b3 misread: 011000 with 010000's check bits
        let mut seq = bad.clone();
        seq.extend(&check.tokens_of(0b100111)[1..]);
        let released = feed(&mut p, &seq);
        assert_eq!(released.len(), 1);
        assert_eq!(released[0].1.payload, 0b100111);
        assert_eq!(released[0].1.token_stamps_ns.len(), 23);
        assert_eq!(released[0].1.check(), Ok(()));
        assert_eq!(p.check_failures(), 1);
        // The paper's parser releases the misread frame.
        let mut paper = FrameParser::new();
        let got = feed(&mut paper, &FrameCheck::None.tokens_of(0b011000));
        assert_eq!(got[0].1.payload, 0b011000);
        assert_eq!(paper.check_failures(), 0);
        assert_eq!("crc3".parse(), Ok(FrameCheck::Crc3));
        let e = "crc8".parse::<FrameCheck>().unwrap_err();
        assert!(e.contains("frame_check = \"crc8\""), "{e}");
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

        /// With a check, releases happen exactly where the last frame-length tokens are a
        /// frame whose check agrees; every other full-length match is counted as a failure.
        #[test]
        fn checked_frames_release_iff_valid(
            bits in prop::collection::vec((0u8..64, any::<bool>(), 0usize..9), 0..6),
            crc in any::<bool>(),
        ) {
            let check = if crc { FrameCheck::Crc3 } else { FrameCheck::Parity };
            let len = check.frame_tokens();
            let mut seq = Vec::new();
            for (payload, corrupt, k) in bits {
                let mut f = check.tokens_of(payload);
                if corrupt {
                    let i = 3 + 2 * (k % (6 + check.bits()));
                    f[i] = if f[i] == Token::Bit1 { Token::Bit0 } else { Token::Bit1 };
                }
                seq.extend(f);
            }
            let mut p = FrameParser::with_check(check);
            let mut shaped = 0u64;
            for (i, &t) in seq.iter().enumerate() {
                let got = p.push(t, 10 * i as u64);
                let window = (i + 1 >= len).then(|| &seq[i + 1 - len..=i]);
                let valid = window.is_some_and(|w| is_valid_frame_of(check, w));
                shaped += u64::from(window.is_some_and(|w| is_prefix_of(check, w)));
                prop_assert_eq!(got.is_some(), valid, "at token {} of {:?}", i, seq);
            }
            let released = seq.len() / len;
            prop_assert!(p.check_failures() <= shaped);
            prop_assert!(p.check_failures() <= released as u64);
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
