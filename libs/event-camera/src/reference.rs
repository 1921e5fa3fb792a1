//! Straightforward scalar reference converter: the executable definition of the semantics.
//!
//! Deliberately naive — one f64 log per pixel per frame, no tables, no bounds — so that it can be
//! read against the specification line by line. The fast [`crate::Converter`] must produce
//! bit-identical event lists; the test suite checks that on random, structured and rendered
//! frames. It is public so integration tests and benchmarks can compare against it.

use crate::error::ConvertError;
use crate::event::{Event, Polarity};
use crate::luminance::log_luminance;

#[derive(Clone, Copy)]
struct Pixel {
    /// L of the first frame.
    l_init: f64,
    /// Integer level n: the reference is L_init + n·C, never an accumulated float.
    level: i32,
    /// L of the previous frame (start of the current interpolation interval).
    l_prev: f64,
}

/// The reference converter (see the crate docs for the exact rules).
#[derive(Clone)]
pub struct ReferenceConverter {
    width: u16,
    height: u16,
    threshold: f64,
    last_stamp_ns: u64,
    pixels: Vec<Pixel>,
}

impl std::fmt::Debug for ReferenceConverter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ReferenceConverter")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("threshold", &self.threshold)
            .field("last_stamp_ns", &self.last_stamp_ns)
            .finish_non_exhaustive()
    }
}

impl ReferenceConverter {
    pub fn new(width: u16, height: u16, threshold: f64) -> Result<Self, ConvertError> {
        ConvertError::check_sensor(width, height, threshold)?;
        Ok(Self {
            width,
            height,
            threshold,
            last_stamp_ns: 0,
            pixels: Vec::new(),
        })
    }

    /// Converts one frame; returns the events of the interval ending at `stamp_ns`, sorted by
    /// (time, pixel index, crossing order). The first frame only initialises.
    pub fn push(&mut self, stamp_ns: u64, rgb: &[u8]) -> Result<Vec<Event>, ConvertError> {
        let (w, h) = (usize::from(self.width), usize::from(self.height));
        ConvertError::check_frame(rgb, self.width, self.height)?;
        let lum = |i: usize| log_luminance(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
        if self.pixels.is_empty() {
            self.pixels = (0..w * h)
                .map(|i| {
                    let l = lum(i);
                    Pixel {
                        l_init: l,
                        level: 0,
                        l_prev: l,
                    }
                })
                .collect();
            self.last_stamp_ns = stamp_ns;
            return Ok(Vec::new());
        }
        ConvertError::check_stamp(stamp_ns, self.last_stamp_ns)?;
        let (t0, dt) = (self.last_stamp_ns, stamp_ns - self.last_stamp_ns);
        let c = self.threshold;
        // (t, pixel index, crossing order, polarity)
        let mut crossings: Vec<(u64, usize, u32, Polarity)> = Vec::new();
        for (i, px) in self.pixels.iter_mut().enumerate() {
            let l = lum(i);
            let d0 = px.l_prev - px.l_init;
            let d1 = l - px.l_init;
            let mut order = 0;
            let time_of = |level: i32| {
                let frac = (f64::from(level) * c - d0) / (d1 - d0);
                t0 + ((frac * dt as f64).ceil() as u64).clamp(1, dt)
            };
            while d1 >= f64::from(px.level + 1) * c {
                px.level += 1;
                crossings.push((time_of(px.level), i, order, Polarity::On));
                order += 1;
            }
            while d1 <= f64::from(px.level - 1) * c {
                px.level -= 1;
                crossings.push((time_of(px.level), i, order, Polarity::Off));
                order += 1;
            }
            px.l_prev = l;
        }
        crossings.sort_by_key(|&(t, i, order, _)| (t, i, order));
        self.last_stamp_ns = stamp_ns;
        Ok(crossings
            .into_iter()
            .map(|(t_ns, i, _, polarity)| Event {
                t_ns,
                x: (i % w) as u16,
                y: (i / w) as u16,
                polarity,
            })
            .collect())
    }

    /// Current integer level n of pixel (x, y) (0 before the first frame).
    pub fn level(&self, x: u16, y: u16) -> i32 {
        let i = usize::from(y) * usize::from(self.width) + usize::from(x);
        self.pixels.get(i).map_or(0, |p| p.level)
    }
}
