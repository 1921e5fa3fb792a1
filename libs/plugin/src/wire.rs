//! The worker pipe's messages, without I/O of their own: every message is a frame
//! `u32 length | u32 header length | JSON header | bulk bytes` (little-endian), the header
//! saying what the message is and the bulk carrying sensor data as the plug-in reads it with
//! numpy, without a copy: events as packed 13-byte records (`t_ns` i64, `x` u16, `y` u16,
//! `polarity` i8 ±1), an RGB frame as its `H×W×3` bytes. Replies are headers only:
//! `{"ok": …}`, `{"error": "…"}` (the plug-in raised) or `{"malformed": "…"}` (the worker
//! found its output unusable), checked here against what the plug-in's level promises.

use std::io::Read;

use proto::frame::{FRAME_TOKENS, FrameCheck};
use proto::{EventPacket, ReleasedFrame, RgbFrame, Token};
use serde_json::{Value, json};

/// Bytes of one event record in the bulk.
pub const EVENT_RECORD_BYTES: usize = 13;

/// The largest reply a worker may send: replies are points, tokens and frames, a few hundred
/// bytes a tick; a length above this is refused before anything is allocated for it.
pub const MAX_REPLY_BYTES: u32 = 1 << 20;

/// The bytes that go before a frame's `bulk`: the lengths and `header` (sent apart from the
/// bulk, so a frame of pixels is not copied to be framed).
pub fn encode_head(header: &Value, bulk_len: usize) -> Vec<u8> {
    let head = header.to_string().into_bytes();
    let len = 4 + head.len() + bulk_len;
    let mut out = Vec::with_capacity(8 + head.len());
    out.extend_from_slice(&u32::try_from(len).unwrap_or(u32::MAX).to_le_bytes());
    out.extend_from_slice(&u32::try_from(head.len()).unwrap_or(u32::MAX).to_le_bytes());
    out.extend_from_slice(&head);
    out
}

/// One frame's bytes: `header` then `bulk`.
pub fn encode(header: &Value, bulk: &[u8]) -> Vec<u8> {
    let head = header.to_string().into_bytes();
    let len = 4 + head.len() + bulk.len();
    let mut out = Vec::with_capacity(4 + len);
    out.extend_from_slice(&u32::try_from(len).unwrap_or(u32::MAX).to_le_bytes());
    out.extend_from_slice(&u32::try_from(head.len()).unwrap_or(u32::MAX).to_le_bytes());
    out.extend_from_slice(&head);
    out.extend_from_slice(bulk);
    out
}

/// Why a frame read from a worker is unusable.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    #[error("the worker closed its output")]
    Closed,
    #[error("reading the worker's output: {0}")]
    Io(#[from] std::io::Error),
    #[error("a reply claims {claimed} bytes, more than the {max} a reply may have")]
    TooLong { claimed: u32, max: u32 },
    #[error("a reply's header length {header} exceeds its frame's {frame} bytes")]
    BadHeaderLength { header: u32, frame: u32 },
    #[error("a reply's header is not JSON: {0}")]
    Json(#[from] serde_json::Error),
}

/// Reads one frame's header from `r`, refusing lengths above `max` before allocating.
pub fn read_reply(r: &mut impl Read, max: u32) -> Result<Value, FrameError> {
    let mut word = [0u8; 4];
    match r.read_exact(&mut word) {
        Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => return Err(FrameError::Closed),
        other => other?,
    }
    let len = u32::from_le_bytes(word);
    if len > max {
        return Err(FrameError::TooLong { claimed: len, max });
    }
    if len < 4 {
        return Err(FrameError::BadHeaderLength {
            header: 4,
            frame: len,
        });
    }
    let mut frame = vec![0u8; len as usize];
    r.read_exact(&mut frame)?;
    let head_len = u32::from_le_bytes([frame[0], frame[1], frame[2], frame[3]]);
    if head_len > len - 4 {
        return Err(FrameError::BadHeaderLength {
            header: head_len,
            frame: len,
        });
    }
    Ok(serde_json::from_slice(&frame[4..4 + head_len as usize])?)
}

/// A packet's events as the bulk's records.
pub fn events_bulk(packet: &EventPacket) -> Vec<u8> {
    let mut out = Vec::with_capacity(packet.len() * EVENT_RECORD_BYTES);
    for k in 0..packet.len() {
        let t_ns = packet.start_ns as i64 + i64::from(packet.dt_ns[k]);
        let on = packet.on_bits[k / 8] >> (k % 8) & 1 == 1;
        out.extend_from_slice(&t_ns.to_le_bytes());
        out.extend_from_slice(&packet.xs[k].to_le_bytes());
        out.extend_from_slice(&packet.ys[k].to_le_bytes());
        out.push(if on { 1 } else { (-1i8) as u8 });
    }
    out
}

/// An event packet's header (its events go in the bulk).
pub fn events_header(observer: &str, packet: &EventPacket, ego: Option<[[f64; 3]; 3]>) -> Value {
    json!({
        "op": "events", "observer": observer, "seq": packet.seq,
        "start_ns": packet.start_ns, "end_ns": packet.end_ns,
        "width": packet.width, "height": packet.height,
        "valid": packet.valid, "continuous": packet.continuous, "ego": ego,
    })
}

/// An RGB frame's header (its pixels go in the bulk).
pub fn rgb_header(observer: &str, frame: &RgbFrame, ego: Option<[[f64; 3]; 3]>) -> Value {
    json!({
        "op": "rgb", "observer": observer, "seq": frame.seq, "stamp_ns": frame.stamp_ns,
        "width": frame.width, "height": frame.height,
        "valid": frame.valid, "continuous": frame.continuous, "ego": ego,
    })
}

/// A token's name on the pipe (`NULL`, `START`, `BIT0`, `BIT1`, `END`, `UNKNOWN`).
pub fn token_name(token: Token) -> String {
    format!("{token:?}").to_uppercase()
}

/// What a reply holds: the plug-in's value, or the exception it raised.
pub fn reply_value(reply: Value) -> Result<Value, Result<String, String>> {
    match reply {
        Value::Object(mut o) => {
            if let Some(error) = o.remove("error") {
                return Err(Ok(error.as_str().unwrap_or("(no message)").to_owned()));
            }
            if let Some(why) = o.remove("malformed") {
                return Err(Err(why.as_str().unwrap_or("(no reason)").to_owned()));
            }
            o.remove("ok")
                .ok_or_else(|| Err("a reply holds neither \"ok\" nor \"error\"".to_owned()))
        }
        _ => Err(Err("a reply is not a JSON object".to_owned())),
    }
}

fn stamp(v: &Value, what: &str) -> Result<u64, String> {
    v.as_u64()
        .ok_or_else(|| format!("{what} is not a non-negative integer of nanoseconds: {v}"))
}

/// A point: `[x, y]` finite pixels, or `null` (no target). A coordinate is a JSON number or a
/// decimal string (the worker sends Python's `repr`, which Rust's parser reads back to the very
/// same `f64`: a JSON number's parse may be off by one unit in the last place, and a wrapped
/// receiver's track must equal the native one to the bit).
pub fn parse_point(v: &Value) -> Result<Option<[f64; 2]>, String> {
    if v.is_null() {
        return Ok(None);
    }
    let xy = v
        .as_array()
        .filter(|a| a.len() == 2)
        .ok_or_else(|| format!("a point is [x, y] or None, not {v}"))?;
    let coordinate = |c: &Value| {
        c.as_f64()
            .or_else(|| c.as_str().and_then(|s| s.parse::<f64>().ok()))
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("a point's coordinate is not a finite number: {c}"))
    };
    Ok(Some([coordinate(&xy[0])?, coordinate(&xy[1])?]))
}

/// Tokens: `[[NAME, stamp_ns], …]`, stamps not decreasing, none after `latest_ns` (a token
/// cannot be confirmed after the input it was read from) nor before `earliest_ns`.
pub fn parse_tokens(
    v: &Value,
    earliest_ns: u64,
    latest_ns: u64,
) -> Result<Vec<(Token, u64)>, String> {
    let items = v
        .as_array()
        .ok_or_else(|| format!("tokens are a list of [NAME, stamp_ns], not {v}"))?;
    let mut out = Vec::with_capacity(items.len());
    let mut previous_ns = earliest_ns;
    for (k, item) in items.iter().enumerate() {
        let pair = item
            .as_array()
            .filter(|a| a.len() == 2)
            .ok_or_else(|| format!("token {k} is not [NAME, stamp_ns]: {item}"))?;
        let name = pair[0].as_str().unwrap_or_default();
        let token = Token::ALL
            .into_iter()
            .find(|&t| token_name(t) == name)
            .ok_or_else(|| {
                format!(
                    "token {k}: {} is not NULL, START, BIT0, BIT1, END or UNKNOWN",
                    pair[0]
                )
            })?;
        let stamp_ns = stamp(&pair[1], &format!("token {k}'s stamp"))?;
        if stamp_ns < previous_ns || stamp_ns > latest_ns {
            return Err(format!(
                "token {k}'s stamp {stamp_ns} ns is outside [{previous_ns}, {latest_ns}] \
                 (stamps do not decrease and no token comes after its input)"
            ));
        }
        previous_ns = stamp_ns;
        out.push((token, stamp_ns));
    }
    Ok(out)
}

/// Released frames: `[[payload, [17 stamps]], …]`, payload 0…63, stamps not decreasing and
/// none after `latest_ns`.
pub fn parse_frames(v: &Value, latest_ns: u64) -> Result<Vec<ReleasedFrame>, String> {
    let items = v
        .as_array()
        .ok_or_else(|| format!("frames are a list of [payload, [stamp_ns × 17]], not {v}"))?;
    let mut out = Vec::with_capacity(items.len());
    for (k, item) in items.iter().enumerate() {
        let pair = item
            .as_array()
            .filter(|a| a.len() == 2)
            .ok_or_else(|| format!("frame {k} is not [payload, stamps]: {item}"))?;
        let payload = pair[0]
            .as_u64()
            .filter(|&p| p < 64)
            .ok_or_else(|| format!("frame {k}'s payload {} is not 0…63", pair[0]))?;
        let stamps = pair[1]
            .as_array()
            .filter(|s| FrameCheck::for_frame_tokens(s.len()).is_some())
            .ok_or_else(|| {
                format!(
                    "frame {k} does not have {FRAME_TOKENS} token stamps (19 or 23 with a check)"
                )
            })?;
        let token_stamps_ns = stamps
            .iter()
            .map(|s| stamp(s, &format!("a stamp of frame {k}")))
            .collect::<Result<Vec<_>, _>>()?;
        if token_stamps_ns.windows(2).any(|w| w[1] < w[0]) {
            return Err(format!("frame {k}'s token stamps decrease"));
        }
        if token_stamps_ns.last().is_some_and(|&t| t > latest_ns) {
            return Err(format!(
                "frame {k} is released after its input ({latest_ns} ns)"
            ));
        }
        out.push(ReleasedFrame {
            payload: payload as u8,
            token_stamps_ns,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_reads_back_and_lengths_are_checked_before_allocating() {
        let bytes = encode(&json!({"ok": {"point_px": [1.5, 2.0]}}), &[]);
        let v = read_reply(&mut bytes.as_slice(), MAX_REPLY_BYTES).unwrap();
        assert_eq!(
            parse_point(&reply_value(v).unwrap()["point_px"]).unwrap(),
            Some([1.5, 2.0])
        );
        let huge = u32::MAX.to_le_bytes();
        assert!(matches!(
            read_reply(&mut huge.as_slice(), MAX_REPLY_BYTES),
            Err(FrameError::TooLong { .. })
        ));
        let mut lying = 8u32.to_le_bytes().to_vec();
        lying.extend_from_slice(&100u32.to_le_bytes());
        lying.extend_from_slice(b"{}{}");
        assert!(matches!(
            read_reply(&mut lying.as_slice(), MAX_REPLY_BYTES),
            Err(FrameError::BadHeaderLength { .. })
        ));
        assert!(matches!(
            read_reply(&mut [].as_slice(), 64),
            Err(FrameError::Closed)
        ));
    }

    #[test]
    fn events_become_records() {
        let packet = EventPacket {
            seq: 0,
            start_ns: 1_000,
            end_ns: 41_000,
            width: 640,
            height: 480,
            valid: true,
            continuous: true,
            xs: vec![3, 639],
            ys: vec![4, 479],
            dt_ns: vec![5, 40_000],
            on_bits: vec![0b10],
        };
        let bulk = events_bulk(&packet);
        assert_eq!(bulk.len(), 2 * EVENT_RECORD_BYTES);
        assert_eq!(i64::from_le_bytes(bulk[..8].try_into().unwrap()), 1_005);
        assert_eq!(bulk[12] as i8, -1);
        assert_eq!(u16::from_le_bytes([bulk[21], bulk[22]]), 639);
        assert_eq!(u16::from_le_bytes([bulk[23], bulk[24]]), 479);
        assert_eq!(bulk[25] as i8, 1);
    }

    #[test]
    fn malformed_outputs_are_refused_saying_where() {
        for (v, why) in [
            (json!([1.0]), "[x, y]"),
            (json!(["a", 1.0]), "finite"),
            (json!(["inf", 1.0]), "finite"),
        ] {
            assert!(parse_point(&v).unwrap_err().contains(why), "{v}");
        }
        // Python's repr of a float reads back to the same bits.
        let x = 0.1f64 + 0.2;
        assert_eq!(
            parse_point(&json!([format!("{x:?}"), "-3.5e-7"])).unwrap(),
            Some([x, -3.5e-7])
        );
        assert!(
            parse_tokens(&json!([["NULL", 5], ["BIT2", 6]]), 0, 10)
                .unwrap_err()
                .contains("token 1")
        );
        assert!(
            parse_tokens(&json!([["NULL", 11]]), 0, 10)
                .unwrap_err()
                .contains("outside")
        );
        assert!(
            parse_tokens(&json!([["NULL", 7], ["END", 6]]), 0, 10)
                .unwrap_err()
                .contains("token 1")
        );
        assert_eq!(
            parse_tokens(&json!([["START", 3]]), 0, 10).unwrap(),
            vec![(Token::Start, 3)]
        );
        let stamps: Vec<u64> = (0..17).collect();
        assert_eq!(
            parse_frames(&json!([[26, stamps]]), 16).unwrap()[0].payload,
            26
        );
        assert!(
            parse_frames(&json!([[64, stamps]]), 16)
                .unwrap_err()
                .contains("0…63")
        );
        assert!(
            parse_frames(&json!([[1, [1, 2]]]), 16)
                .unwrap_err()
                .contains("17")
        );
        assert!(
            parse_frames(&json!([[1, stamps]]), 15)
                .unwrap_err()
                .contains("after")
        );
    }
}
