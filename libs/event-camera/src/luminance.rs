//! The log-luminance proxy `L = ln(max(0.299R + 0.587G + 0.114B, 1))`, defined bit-exactly.
//!
//! The weighted sum is formed exactly in integers as a *luminance key*
//! `key = 299R + 587G + 114B = 1000·Y` (0..=255 000), and `L` is then
//! `ln(max(key as f64 / 1000.0, 1.0))` in f64. Dividing the exact integer once makes `Y` the
//! correctly rounded f64 of the true luminance, so the definition does not depend on the order of
//! floating-point additions. Every implementation in this crate goes through
//! [`log_luminance_of_key`]; the fast path merely tabulates it for all 255 001 keys (same
//! function, same process, hence the same bits).

use std::sync::OnceLock;

/// Largest luminance key (white): 299·255 + 587·255 + 114·255.
pub const MAX_KEY: u32 = 255_000;

/// Exact luminance key `1000·Y` of an 8-bit RGB triple.
#[inline(always)]
pub fn luminance_key(r: u8, g: u8, b: u8) -> u32 {
    299 * u32::from(r) + 587 * u32::from(g) + 114 * u32::from(b)
}

/// `L = ln(max(key / 1000, 1))` in f64: the one definition of the log-luminance proxy.
#[inline]
pub fn log_luminance_of_key(key: u32) -> f64 {
    (f64::from(key) / 1000.0).max(1.0).ln()
}

/// Log luminance of an 8-bit RGB triple.
#[inline]
pub fn log_luminance(r: u8, g: u8, b: u8) -> f64 {
    log_luminance_of_key(luminance_key(r, g, b))
}

/// `log_luminance_of_key` for every key `0..=MAX_KEY`, built once per process (2 MB).
///
/// The table is non-decreasing in the key (checked by a test over every entry), which is what
/// lets the fast converter describe each pixel's "no event" set as one contiguous key interval.
pub fn log_table() -> &'static [f64] {
    static TABLE: OnceLock<Box<[f64]>> = OnceLock::new();
    TABLE.get_or_init(|| (0..=MAX_KEY).map(log_luminance_of_key).collect())
}

/// `L` on v2e's lin-log curve with its knee at luminance `knee_dn` (≥ 1): linear below the
/// knee, `L = Y·ln(knee)/knee`, and `ln Y` above; continuous and increasing. v2e
/// (`emulator_utils.lin_log`, knee 20 DN) keeps dark pixels from amplifying tiny changes into
/// events the way a pure log would.
pub fn lin_log_of_key(key: u32, knee_dn: f64) -> f64 {
    let y = f64::from(key) / 1000.0;
    if y <= knee_dn {
        y * (knee_dn.ln() / knee_dn)
    } else {
        y.ln()
    }
}

/// The table of `L` for every key `0..=MAX_KEY`: [`log_table`] when `linlog_dn` is 0, else
/// [`lin_log_of_key`] with that knee. Each distinct knee is built once per process and kept
/// (2 MB each; a process uses one or two).
pub fn table_for(linlog_dn: f64) -> &'static [f64] {
    /// (knee's bits, its table), one entry per knee used.
    type Tables = std::sync::Mutex<Vec<(u64, &'static [f64])>>;
    static TABLES: OnceLock<Tables> = OnceLock::new();
    if linlog_dn == 0.0 {
        return log_table();
    }
    let tables = TABLES.get_or_init(Default::default);
    let mut tables = tables
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some(&(_, t)) = tables.iter().find(|(bits, _)| *bits == linlog_dn.to_bits()) {
        return t;
    }
    let table: &'static [f64] = Box::leak(
        (0..=MAX_KEY)
            .map(|key| lin_log_of_key(key, linlog_dn))
            .collect::<Box<[f64]>>(),
    );
    tables.push((linlog_dn.to_bits(), table));
    table
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_is_thousand_times_luminance() {
        assert_eq!(luminance_key(0, 0, 0), 0);
        assert_eq!(luminance_key(255, 255, 255), MAX_KEY);
        assert_eq!(luminance_key(1, 0, 0), 299);
        assert_eq!(luminance_key(0, 1, 0), 587);
        assert_eq!(luminance_key(0, 0, 1), 114);
        assert_eq!(luminance_key(10, 20, 30), 2990 + 11740 + 3420);
    }

    #[test]
    fn dark_pixels_clamp_to_zero_and_white_is_ln_255() {
        assert_eq!(log_luminance(0, 0, 0), 0.0);
        // Y = 0.999 < 1 clamps; Y = 1 exactly is ln 1 = 0 as well.
        assert_eq!(log_luminance_of_key(999), 0.0);
        assert_eq!(log_luminance_of_key(1000), 0.0);
        assert!(log_luminance_of_key(1001) > 0.0);
        assert_eq!(log_luminance(255, 255, 255), 255f64.ln());
        assert_eq!(log_luminance(100, 100, 100), 100f64.ln());
    }

    #[test]
    fn table_matches_function_and_is_monotone() {
        let table = log_table();
        assert_eq!(table.len(), MAX_KEY as usize + 1);
        for (key, &l) in table.iter().enumerate() {
            assert_eq!(
                l.to_bits(),
                log_luminance_of_key(key as u32).to_bits(),
                "key {key}"
            );
        }
        // Strictly increasing above Y = 1, flat (0) below.
        assert!(table[..=1000].iter().all(|&l| l == 0.0));
        assert!(table[1000..].windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn lin_log_is_linear_below_the_knee_log_above_and_increasing() {
        let table = table_for(20.0);
        assert_eq!(table[0], 0.0);
        assert!((table[10_000] - 10.0 * 20f64.ln() / 20.0).abs() < 1e-15);
        assert!((table[20_000] - 20f64.ln()).abs() < 1e-12);
        assert_eq!(table[100_000], 100f64.ln());
        assert!(table.windows(2).all(|w| w[0] < w[1]));
        assert!(std::ptr::eq(table, table_for(20.0)));
        assert!(std::ptr::eq(table_for(0.0), log_table()));
        // Knee 1 is today's curve above Y = 1 (and 0 below, where today's clamps).
        assert_eq!(table_for(1.0)[5000], log_table()[5000]);
    }
}
