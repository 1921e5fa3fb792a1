//! The motion alphabet's symbols: receiver tokens and the performer's actions.
//!
//! [`Action::keypoints`] is the single source of truth for the shape of every action: the
//! performer flies these polylines (scaled to metres) and the receivers' templates are built from
//! the very same points (see [`crate::alphabet`]).

use serde::{Deserialize, Serialize};

/// One confirmed observation of a receiver.
///
/// `Null` is a confirmed hover; `Unknown` is an observation that matched no symbol and
/// invalidates any incomplete frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum Token {
    Null,
    Start,
    Bit0,
    Bit1,
    End,
    Unknown,
}

impl Token {
    /// Every token, in declaration order.
    pub const ALL: [Token; 6] = [
        Token::Null,
        Token::Start,
        Token::Bit0,
        Token::Bit1,
        Token::End,
        Token::Unknown,
    ];

    /// The motion action this token stands for, if it is one.
    pub fn action(self) -> Option<Action> {
        match self {
            Token::Start => Some(Action::Start),
            Token::Bit0 => Some(Action::Bit0),
            Token::Bit1 => Some(Action::Bit1),
            Token::End => Some(Action::End),
            Token::Null | Token::Unknown => None,
        }
    }

    /// Short upper-case label used in logs and records (`NULL`, `START`, `0`, `1`, `END`, `?`).
    pub fn label(self) -> &'static str {
        match self {
            Token::Null => "NULL",
            Token::Start => "START",
            Token::Bit0 => "0",
            Token::Bit1 => "1",
            Token::End => "END",
            Token::Unknown => "?",
        }
    }
}

impl std::fmt::Display for Token {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.label())
    }
}

/// A motion primitive flown by the performer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum Action {
    /// Repeated up–down motion.
    Start,
    /// V-shaped path.
    Bit0,
    /// Inverted V-shaped path.
    Bit1,
    /// Repeated left–right motion.
    End,
}

const START_KEYPOINTS: [[f64; 2]; 6] = [
    [0.0, 0.0],
    [0.0, 1.0],
    [0.0, -1.0],
    [0.0, 1.0],
    [0.0, -1.0],
    [0.0, 0.0],
];
const END_KEYPOINTS: [[f64; 2]; 6] = [
    [0.0, 0.0],
    [1.0, 0.0],
    [-1.0, 0.0],
    [1.0, 0.0],
    [-1.0, 0.0],
    [0.0, 0.0],
];
const BIT0_KEYPOINTS: [[f64; 2]; 4] = [[0.0, 0.0], [0.5, -1.0], [1.0, 0.0], [0.0, 0.0]];
const BIT1_KEYPOINTS: [[f64; 2]; 4] = [[0.0, 0.0], [0.5, 1.0], [1.0, 0.0], [0.0, 0.0]];

impl Action {
    /// Every action, in template order.
    pub const ALL: [Action; 4] = [Action::Start, Action::Bit0, Action::Bit1, Action::End];

    /// The action's polyline in performer-view units: `u` to the observer's right, `v` up, one
    /// unit = one excursion amplitude. Every polyline starts and ends at the origin.
    pub fn keypoints(self) -> &'static [[f64; 2]] {
        match self {
            Action::Start => &START_KEYPOINTS,
            Action::End => &END_KEYPOINTS,
            Action::Bit0 => &BIT0_KEYPOINTS,
            Action::Bit1 => &BIT1_KEYPOINTS,
        }
    }

    /// The action's polyline in image coordinates (x right, y down): `(u, −v)`.
    pub fn image_polyline(self) -> Vec<[f64; 2]> {
        self.keypoints().iter().map(|&[u, v]| [u, -v]).collect()
    }

    /// The action for a payload bit.
    pub fn for_bit(bit: bool) -> Action {
        if bit { Action::Bit1 } else { Action::Bit0 }
    }

    /// The token a receiver reports for this action.
    pub fn token(self) -> Token {
        match self {
            Action::Start => Token::Start,
            Action::Bit0 => Token::Bit0,
            Action::Bit1 => Token::Bit1,
            Action::End => Token::End,
        }
    }

    /// Index into [`Action::ALL`].
    pub fn index(self) -> usize {
        match self {
            Action::Start => 0,
            Action::Bit0 => 1,
            Action::Bit1 => 2,
            Action::End => 3,
        }
    }
}

impl From<Action> for Token {
    fn from(a: Action) -> Token {
        a.token()
    }
}

impl std::fmt::Display for Action {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.token().label())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_action_returns_to_its_start_and_maps_to_its_token() {
        for a in Action::ALL {
            let k = a.keypoints();
            assert_eq!(k.first(), Some(&[0.0, 0.0]));
            assert_eq!(k.last(), Some(&[0.0, 0.0]));
            assert_eq!(a.token().action(), Some(a));
            assert_eq!(Action::ALL[a.index()], a);
        }
        assert_eq!(Token::Null.action(), None);
        assert_eq!(Token::Unknown.action(), None);
    }

    #[test]
    fn bit0_dips_down_in_the_image_and_bit1_rises() {
        // Image y points down: the V's apex has positive y, the inverted V's negative y.
        assert_eq!(Action::Bit0.image_polyline()[1], [0.5, 1.0]);
        assert_eq!(Action::Bit1.image_polyline()[1], [0.5, -1.0]);
        assert_eq!(Action::for_bit(false), Action::Bit0);
        assert_eq!(Action::for_bit(true), Action::Bit1);
    }
}
