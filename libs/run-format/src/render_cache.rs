//! The lab's render cache entries (`<key>.renders`), as bytes: magic, metadata length (u64 LE),
//! metadata (JSON), the pixel section, SHA-256 of all before it. This module owns encoding an
//! entry and decoding one with every check its bytes allow — magic, digest, lengths, format,
//! that each render's pixels fit its frame and that the pixel section holds exactly what the
//! metadata lists. Entries are shared on cluster file systems, so a damaged one must be refused
//! with a reason, never panic or allocate what its length fields claim. The lab keeps the rest:
//! keys, locking, files, flying and what the ideal receivers' output (`I`) is.
//!
//! Decoding copies each render's pixels out of the entry once the metadata's length for it has
//! been checked against what remains, so it holds at most the entry's size again, plus its
//! metadata parsed.

use proto::FrameChange;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::trial_record::Provenance;

/// The first bytes of an entry (format version 1).
pub const MAGIC: &[u8; 8] = b"WGLRNDR1";
/// The format tag inside an entry's metadata and its key.
pub const FORMAT: &str = "waggle-renders-1";
/// The trailing SHA-256's length.
pub const DIGEST_LEN: usize = 32;
/// Magic and metadata length.
const HEAD_LEN: usize = MAGIC.len() + 8;

/// Why an entry is refused.
#[derive(Debug, thiserror::Error)]
pub enum RenderCacheError {
    #[error("{0} bytes: shorter than an entry's header")]
    Short(usize),
    #[error("not a render cache entry")]
    Magic,
    #[error("its SHA-256 does not match its content")]
    Digest,
    #[error("its metadata length runs past its end")]
    MetaLength,
    #[error("its metadata")]
    Meta(#[source] serde_json::Error),
    #[error("format {0} is not {FORMAT}")]
    Format(String),
    /// The entry is another key's.
    #[error("it holds entry {0}")]
    Key(String),
    #[error("{tracks} tracks for {observers} observers")]
    Tracks { tracks: usize, observers: usize },
    /// A render's metadata does not fit its frame.
    #[error("track {track}, render {render}")]
    Render {
        track: usize,
        render: usize,
        #[source]
        source: CachedRenderError,
    },
    #[error("track {track}, render {render}: pixels run past the end")]
    PixelsPastEnd { track: usize, render: usize },
    #[error("{0} bytes after the last render")]
    Trailing(usize),
    /// Encoding: the metadata does not print.
    #[error("writing a render cache entry's metadata")]
    Print(#[source] serde_json::Error),
}

/// Why one render's metadata is refused: its pixels must fit its frame, so that replaying it
/// cannot index outside the frame.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CachedRenderError {
    #[error("frame of {frame_len} bytes is not rows {width} pixels wide")]
    Rows { frame_len: usize, width: usize },
    #[error("rectangle {rect:?} outside a {width}×{height} frame")]
    Outside {
        rect: proto::PixelRect,
        width: usize,
        height: usize,
    },
    #[error("the first render is not whole")]
    NotWhole,
    #[error("{len} bytes of pixels where {want} are due")]
    Length { len: usize, want: usize },
}

/// An entry's metadata (JSON): what the pixel section holds, and the flight's results. `I` is
/// the ideal receivers' output, the lab's type.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Meta<I> {
    pub format: String,
    pub key: String,
    /// The flight's specification as the writing binary prints it (for a reader of the cache).
    pub spec: String,
    pub provenance: Provenance,
    pub ideal: I,
    pub sim_ns: u64,
    pub performer_max_tracking_error_m: f64,
    pub contact_steps: u64,
    pub tracks: Vec<TrackMeta>,
}

/// One camera's renders as the metadata lists them.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct TrackMeta {
    pub frame_len: usize,
    pub width: usize,
    /// (stamp, change, bytes of its pixels in the pixel section).
    pub updates: Vec<(u64, FrameChange, usize)>,
}

/// A decoded entry: its metadata and each track's renders' pixels, in the metadata's order.
#[derive(Debug, Clone, PartialEq)]
pub struct CacheEntry<I> {
    pub meta: Meta<I>,
    /// `pixels[track][render]`.
    pub pixels: Vec<Vec<Vec<u8>>>,
}

impl<I: Serialize> CacheEntry<I> {
    /// Its bytes, as [`encode`] writes them.
    ///
    /// # Errors
    ///
    /// As [`encode`].
    pub fn encode(&self) -> Result<Vec<u8>, RenderCacheError> {
        encode(&self.meta, self.pixels.iter().flatten().map(Vec::as_slice))
    }
}

/// What the reader asks for: the entry of this key, for this many observers.
#[derive(Debug, Clone, Copy)]
pub struct EntryFor<'a> {
    pub key: &'a str,
    pub observers: usize,
}

/// An entry's bytes: `meta`, then `pixels` (every render's, track by track, in the metadata's
/// order), then the digest.
///
/// # Errors
///
/// When the metadata does not print as JSON.
pub fn encode<'a, I: Serialize>(
    meta: &Meta<I>,
    pixels: impl IntoIterator<Item = &'a [u8]>,
) -> Result<Vec<u8>, RenderCacheError> {
    let meta_json = serde_json::to_vec(meta).map_err(RenderCacheError::Print)?;
    let section: usize = meta
        .tracks
        .iter()
        .flat_map(|t| &t.updates)
        .map(|u| u.2)
        .sum();
    let mut out = Vec::with_capacity(HEAD_LEN + meta_json.len() + section + DIGEST_LEN);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&(meta_json.len() as u64).to_le_bytes());
    out.extend_from_slice(&meta_json);
    for p in pixels {
        out.extend_from_slice(p);
    }
    let digest = Sha256::digest(&out);
    out.extend_from_slice(&digest);
    Ok(out)
}

/// Decodes and checks an entry; with `expected`, also that it is that key's, for that many
/// observers.
///
/// # Errors
///
/// The first check that fails, naming the track and render where the pixels are at fault.
pub fn decode<I: DeserializeOwned>(
    bytes: &[u8],
    expected: Option<EntryFor<'_>>,
) -> Result<CacheEntry<I>, RenderCacheError> {
    if bytes.len() < HEAD_LEN + DIGEST_LEN {
        return Err(RenderCacheError::Short(bytes.len()));
    }
    if &bytes[..MAGIC.len()] != MAGIC {
        return Err(RenderCacheError::Magic);
    }
    let (body, digest) = bytes.split_at(bytes.len() - DIGEST_LEN);
    if Sha256::digest(body).as_slice() != digest {
        return Err(RenderCacheError::Digest);
    }
    let mut len = [0u8; 8];
    len.copy_from_slice(&bytes[MAGIC.len()..HEAD_LEN]);
    let meta_end = usize::try_from(u64::from_le_bytes(len))
        .ok()
        .and_then(|n| HEAD_LEN.checked_add(n))
        .filter(|&end| end <= body.len())
        .ok_or(RenderCacheError::MetaLength)?;
    let meta: Meta<I> =
        serde_json::from_slice(&body[HEAD_LEN..meta_end]).map_err(RenderCacheError::Meta)?;
    if meta.format != FORMAT {
        return Err(RenderCacheError::Format(meta.format));
    }
    if let Some(e) = expected {
        if meta.key != e.key {
            return Err(RenderCacheError::Key(meta.key));
        }
        if meta.tracks.len() != e.observers {
            return Err(RenderCacheError::Tracks {
                tracks: meta.tracks.len(),
                observers: e.observers,
            });
        }
    }
    let mut at = meta_end;
    let mut pixels = Vec::with_capacity(meta.tracks.len());
    for (track, t) in meta.tracks.iter().enumerate() {
        let mut renders = Vec::with_capacity(t.updates.len());
        for (render, &(_, change, len)) in t.updates.iter().enumerate() {
            check_update(t, render, change, len).map_err(|source| RenderCacheError::Render {
                track,
                render,
                source,
            })?;
            // The length was checked against the frame, and is checked against what remains
            // before anything is copied.
            let end = at
                .checked_add(len)
                .filter(|&e| e <= body.len())
                .ok_or(RenderCacheError::PixelsPastEnd { track, render })?;
            renders.push(body[at..end].to_vec());
            at = end;
        }
        pixels.push(renders);
    }
    if at != body.len() {
        return Err(RenderCacheError::Trailing(body.len() - at));
    }
    Ok(CacheEntry { meta, pixels })
}

/// Render `k` of track `t`: its pixels must fit its frame, and the first must be whole.
///
/// # Errors
///
/// Saying which of those fails.
pub fn check_update(
    t: &TrackMeta,
    k: usize,
    change: FrameChange,
    len: usize,
) -> Result<(), CachedRenderError> {
    let row = t.width.checked_mul(3).filter(|&r| r > 0);
    let Some(row) = row.filter(|&r| t.frame_len.is_multiple_of(r)) else {
        return Err(CachedRenderError::Rows {
            frame_len: t.frame_len,
            width: t.width,
        });
    };
    let height = t.frame_len / row;
    let want = match change {
        FrameChange::Nothing => 0,
        FrameChange::All => t.frame_len,
        FrameChange::Within(r) => {
            let (x, y) = (usize::from(r.x), usize::from(r.y));
            let (w, h) = (usize::from(r.width), usize::from(r.height));
            if x + w > t.width || y + h > height {
                return Err(CachedRenderError::Outside {
                    rect: r,
                    width: t.width,
                    height,
                });
            }
            3 * w * h
        }
    };
    if k == 0 && change != FrameChange::All {
        return Err(CachedRenderError::NotWhole);
    }
    if len != want {
        return Err(CachedRenderError::Length { len, want });
    }
    Ok(())
}

#[cfg(test)]
mod tests;
