//! The six-bit task offer `ss|qq|cc` and the shared task map.
//!
//! Site ids 1 and 2 name the known sites A and B (coordinates come from the shared map in
//! [`crate::scene`], never from the message); every other id is rejected. Quality and capacity
//! range over 0–3, and either being 0 withdraws the offer.

use serde::{Deserialize, Serialize};

use crate::scene::{SITE_A_M, SITE_B_M};

/// Largest value of the two-bit quality and capacity fields.
pub const FIELD_MAX: u8 = 3;

/// Why a payload or offer was rejected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PayloadError {
    #[error("payload must have 6 bits, got {len} characters")]
    WrongLength { len: usize },
    #[error("payload character {position} is {ch:?}, not 0 or 1")]
    NotBinary { position: usize, ch: char },
    #[error("payload value {value} does not fit in 6 bits")]
    TooWide { value: u32 },
    #[error("unknown site id {id} (only 1 = A and 2 = B exist)")]
    UnknownSite { id: u8 },
    #[error("unknown site name {name:?} (expected A or B)")]
    UnknownSiteName { name: String },
    #[error("{field} {value} is out of range 0..=3")]
    FieldOutOfRange { field: &'static str, value: u32 },
}

/// A task site of the shared map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum Site {
    A,
    B,
}

impl Site {
    /// Both sites, in site-id order.
    pub const ALL: [Site; 2] = [Site::A, Site::B];

    /// The two-bit payload id (A = 1, B = 2).
    pub fn id(self) -> u8 {
        match self {
            Site::A => 1,
            Site::B => 2,
        }
    }

    pub fn from_id(id: u8) -> Result<Site, PayloadError> {
        match id {
            1 => Ok(Site::A),
            2 => Ok(Site::B),
            _ => Err(PayloadError::UnknownSite { id }),
        }
    }

    /// World position from the shared map, metres.
    pub fn position_m(self) -> [f64; 3] {
        match self {
            Site::A => SITE_A_M,
            Site::B => SITE_B_M,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Site::A => "A",
            Site::B => "B",
        }
    }
}

impl std::fmt::Display for Site {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Site {
    type Err = PayloadError;
    /// Accepts `A`/`B` (any case) or the ids `1`/`2`.
    fn from_str(s: &str) -> Result<Site, PayloadError> {
        match s.trim() {
            "A" | "a" | "1" => Ok(Site::A),
            "B" | "b" | "2" => Ok(Site::B),
            other => Err(PayloadError::UnknownSiteName {
                name: other.to_owned(),
            }),
        }
    }
}

/// A task offer as carried by one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct Offer {
    pub site: Site,
    pub quality: u8,
    pub capacity: u8,
}

impl Offer {
    /// An offer with range-checked fields.
    pub fn new(site: Site, quality: u8, capacity: u8) -> Result<Offer, PayloadError> {
        let offer = Offer {
            site,
            quality,
            capacity,
        };
        offer.check()?;
        Ok(offer)
    }

    /// The withdrawal of `site` as the paper sends it: quality 0 and capacity 0.
    pub fn withdrawal(site: Site) -> Offer {
        Offer {
            site,
            quality: 0,
            capacity: 0,
        }
    }

    /// Checks the field ranges (offers built with struct syntax or decoded from the wire).
    pub fn check(&self) -> Result<(), PayloadError> {
        for (field, value) in [("quality", self.quality), ("capacity", self.capacity)] {
            if value > FIELD_MAX {
                return Err(PayloadError::FieldOutOfRange {
                    field,
                    value: u32::from(value),
                });
            }
        }
        Ok(())
    }

    /// True when the offer withdraws its site (q = 0 or c = 0).
    pub fn withdrawn(&self) -> bool {
        self.quality == 0 || self.capacity == 0
    }

    /// The 6-bit payload value `ss qq cc`.
    pub fn to_payload(&self) -> u8 {
        self.site.id() << 4 | (self.quality & FIELD_MAX) << 2 | (self.capacity & FIELD_MAX)
    }

    pub fn from_payload(value: u8) -> Result<Offer, PayloadError> {
        if value >= 64 {
            return Err(PayloadError::TooWide {
                value: u32::from(value),
            });
        }
        Ok(Offer {
            site: Site::from_id(value >> 4)?,
            quality: value >> 2 & FIELD_MAX,
            capacity: value & FIELD_MAX,
        })
    }

    /// The payload as the six characters `b1 … b6`, e.g. `011010`.
    pub fn to_bits(&self) -> String {
        format!("{:06b}", self.to_payload())
    }

    /// Parses six `0`/`1` characters, b1 first.
    pub fn from_bits(bits: &str) -> Result<Offer, PayloadError> {
        let len = bits.chars().count();
        if len != 6 {
            return Err(PayloadError::WrongLength { len });
        }
        let mut value = 0u8;
        for (position, ch) in bits.chars().enumerate() {
            let bit = match ch {
                '0' => 0,
                '1' => 1,
                _ => return Err(PayloadError::NotBinary { position, ch }),
            };
            value = value << 1 | bit;
        }
        Offer::from_payload(value)
    }
}

impl std::fmt::Display for Offer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.to_bits())
    }
}

impl std::str::FromStr for Offer {
    type Err = PayloadError;
    fn from_str(s: &str) -> Result<Offer, PayloadError> {
        Offer::from_bits(s.trim())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn the_papers_payloads() {
        let a1 = Offer::from_bits("011010").unwrap();
        assert_eq!(
            a1,
            Offer {
                site: Site::A,
                quality: 2,
                capacity: 2
            }
        );
        assert!(!a1.withdrawn());
        let b = Offer::from_bits("100111").unwrap();
        assert_eq!(
            b,
            Offer {
                site: Site::B,
                quality: 1,
                capacity: 3
            }
        );
        let a2 = Offer::from_bits("010000").unwrap();
        assert_eq!(a2, Offer::withdrawal(Site::A));
        assert!(a2.withdrawn());
        assert_eq!(a1.to_payload(), 0b011010);
        assert_eq!(b.to_string(), "100111");
    }

    #[test]
    fn q0_or_c0_withdraws() {
        assert!(Offer::new(Site::B, 0, 3).unwrap().withdrawn());
        assert!(Offer::new(Site::B, 3, 0).unwrap().withdrawn());
        assert!(!Offer::new(Site::B, 1, 1).unwrap().withdrawn());
    }

    #[test]
    fn errors_name_the_problem() {
        assert_eq!(
            Offer::from_bits("01101"),
            Err(PayloadError::WrongLength { len: 5 })
        );
        assert_eq!(
            Offer::from_bits("0110100"),
            Err(PayloadError::WrongLength { len: 7 })
        );
        assert_eq!(
            Offer::from_bits("01a010"),
            Err(PayloadError::NotBinary {
                position: 2,
                ch: 'a'
            })
        );
        assert_eq!(
            Offer::from_bits("001010"),
            Err(PayloadError::UnknownSite { id: 0 })
        );
        assert_eq!(
            Offer::from_bits("111010"),
            Err(PayloadError::UnknownSite { id: 3 })
        );
        assert_eq!(
            Offer::from_payload(64),
            Err(PayloadError::TooWide { value: 64 })
        );
        assert_eq!(
            Offer::new(Site::A, 4, 1),
            Err(PayloadError::FieldOutOfRange {
                field: "quality",
                value: 4
            })
        );
        assert_eq!(
            Offer::new(Site::A, 1, 9),
            Err(PayloadError::FieldOutOfRange {
                field: "capacity",
                value: 9
            })
        );
        assert!(
            Offer::from_bits("UNKNOWN")
                .unwrap_err()
                .to_string()
                .contains("6 bits")
        );
        assert!("C".parse::<Site>().is_err());
        assert_eq!("b".parse::<Site>(), Ok(Site::B));
    }

    #[test]
    fn sites_come_from_the_shared_map() {
        assert_eq!(Site::A.position_m(), [-1.65, -1.65, 1.3]);
        assert_eq!(Site::B.position_m(), [1.65, -1.65, 1.3]);
    }

    proptest! {
        #[test]
        fn encode_then_decode_is_identity(
            site in prop::sample::select(Site::ALL.to_vec()),
            quality in 0u8..=3,
            capacity in 0u8..=3,
        ) {
            let offer = Offer::new(site, quality, capacity).unwrap();
            prop_assert_eq!(Offer::from_payload(offer.to_payload()), Ok(offer));
            prop_assert_eq!(Offer::from_bits(&offer.to_bits()), Ok(offer));
        }

        #[test]
        fn every_six_bit_value_decodes_iff_its_site_is_1_or_2(value in 0u8..64) {
            match Offer::from_payload(value) {
                Ok(o) => prop_assert_eq!(o.to_payload(), value),
                Err(e) => {
                    let unknown_site = matches!(e, PayloadError::UnknownSite { id: 0 | 3 });
                    prop_assert!(unknown_site, "{:?}", e);
                }
            }
            prop_assert_eq!(Offer::from_payload(value).is_ok(), matches!(value >> 4, 1 | 2));
        }
    }
}
