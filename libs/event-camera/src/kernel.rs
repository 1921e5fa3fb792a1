//! The per-frame scan: integer luminance keys checked against per-pixel "no event" bounds.
//!
//! This is the only code that touches every pixel of every frame, so it is written to
//! auto-vectorise: fixed-size chunks, no branches inside a chunk, no logarithm. It is compiled
//! three times (baseline x86-64 / AVX2 / AVX-512) and the best variant the CPU supports is
//! chosen once at run time; all variants compute the same integers, so the choice cannot change
//! results.

use crate::luminance::luminance_key;

/// Pixels per chunk; a flagged chunk is re-examined pixel by pixel.
pub(crate) const CHUNK: usize = 32;

/// Instruction-set variant of the scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Isa {
    Baseline,
    #[cfg(target_arch = "x86_64")]
    Avx2,
    #[cfg(target_arch = "x86_64")]
    Avx512,
}

impl Isa {
    pub(crate) fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512bw")
            {
                return Isa::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                return Isa::Avx2;
            }
        }
        Isa::Baseline
    }
}

/// Writes every pixel's luminance key into `keys` and the index of every chunk containing a
/// pixel whose key lies outside `[lo, lo + span]` into `flagged` (ascending; cleared first).
///
/// All slices must describe the same pixel count (`rgb` three bytes per pixel).
pub(crate) fn scan(
    isa: Isa,
    rgb: &[u8],
    lo: &[u32],
    span: &[u32],
    keys: &mut [u32],
    flagged: &mut Vec<u32>,
) {
    assert!(
        rgb.len() == 3 * keys.len() && lo.len() == keys.len() && span.len() == keys.len(),
        "scan buffers disagree on the pixel count"
    );
    flagged.clear();
    match isa {
        Isa::Baseline => scan_body(rgb, lo, span, keys, flagged),
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `Isa::Avx2` is only constructed after run-time detection of AVX2.
        Isa::Avx2 => unsafe { scan_avx2(rgb, lo, span, keys, flagged) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `Isa::Avx512` is only constructed after run-time detection of AVX-512 F+BW.
        Isa::Avx512 => unsafe { scan_avx512(rgb, lo, span, keys, flagged) },
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn scan_avx2(rgb: &[u8], lo: &[u32], span: &[u32], keys: &mut [u32], flagged: &mut Vec<u32>) {
    scan_body(rgb, lo, span, keys, flagged)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx2")]
fn scan_avx512(rgb: &[u8], lo: &[u32], span: &[u32], keys: &mut [u32], flagged: &mut Vec<u32>) {
    scan_body(rgb, lo, span, keys, flagged)
}

#[inline(always)]
fn scan_body(rgb: &[u8], lo: &[u32], span: &[u32], keys: &mut [u32], flagged: &mut Vec<u32>) {
    let chunks = rgb
        .chunks_exact(3 * CHUNK)
        .zip(lo.chunks_exact(CHUNK))
        .zip(span.chunks_exact(CHUNK))
        .zip(keys.chunks_exact_mut(CHUNK));
    let mut chunk_index = 0u32;
    for (((px, lo), span), keys) in chunks {
        // Fixed-size views let the compiler drop bounds checks and vectorise the lanes.
        let px: &[u8; 3 * CHUNK] = px.try_into().expect("exact chunk");
        let lo: &[u32; CHUNK] = lo.try_into().expect("exact chunk");
        let span: &[u32; CHUNK] = span.try_into().expect("exact chunk");
        let keys: &mut [u32; CHUNK] = keys.try_into().expect("exact chunk");
        let mut outside = 0u32;
        for j in 0..CHUNK {
            let key = luminance_key(px[3 * j], px[3 * j + 1], px[3 * j + 2]);
            keys[j] = key;
            // One unsigned compare covers both ends: keys below `lo` wrap to huge values.
            outside |= u32::from(key.wrapping_sub(lo[j]) > span[j]);
        }
        if outside != 0 {
            flagged.push(chunk_index);
        }
        chunk_index += 1;
    }
    let done = chunk_index as usize * CHUNK;
    let mut outside = false;
    for i in done..keys.len() {
        let key = luminance_key(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
        keys[i] = key;
        outside |= key.wrapping_sub(lo[i]) > span[i];
    }
    if outside {
        flagged.push(chunk_index);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn variants() -> Vec<Isa> {
        let mut v = vec![Isa::Baseline];
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                v.push(Isa::Avx2);
            }
            if Isa::detect() == Isa::Avx512 {
                v.push(Isa::Avx512);
            }
        }
        v
    }

    #[test]
    fn flags_exactly_the_chunks_with_out_of_bounds_pixels() {
        // 3 full chunks + a 5-pixel tail.
        let n = 3 * CHUNK + 5;
        let rgb: Vec<u8> = (0..3 * n).map(|i| (i * 37 % 251) as u8).collect();
        let want_keys: Vec<u32> = (0..n)
            .map(|i| luminance_key(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]))
            .collect();
        // Bounds exactly [key, key]: in bounds everywhere …
        let mut lo = want_keys.clone();
        let mut span = vec![0; n];
        // … except pixel 1·CHUNK+7 (above) and the last tail pixel (below).
        lo[CHUNK + 7] = want_keys[CHUNK + 7] - 1 - 3;
        span[CHUNK + 7] = 3;
        lo[n - 1] = want_keys[n - 1] + 1;
        for isa in variants() {
            let mut keys = vec![0; n];
            let mut flagged = vec![99];
            scan(isa, &rgb, &lo, &span, &mut keys, &mut flagged);
            assert_eq!(keys, want_keys, "{isa:?}");
            assert_eq!(flagged, vec![1, 3], "{isa:?}");
        }
    }
}
