//! Per observer, the image-plane trajectory behind each decoded symbol over its template (SVG,
//! drawn with `plotters`).
//!
//! The trajectory of a symbol is every track sample the observer published after the NULL
//! confirmation before it, up to the confirmation that classified it — the same span as the
//! receivers' own symbol trajectories. It is drawn as the matcher sees it: resampled to 80
//! arc-length points, first point subtracted, divided by the largest coordinate span.

use anyhow::Result;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::HPos;
use proto::alphabet::{RESAMPLE_POINTS, normalise, resample_arc_length, template, template_errors};
use proto::{Action, Token, TokenEvent, TrackSample};

use super::plot::{hex, text_style};
use super::timeline::action_colour;
use run_eval::summary::ns_s;
use run_format::run_dir::ObserverRecord;

/// One decoded symbol with the track behind it.
#[derive(Debug, Clone, PartialEq)]
pub struct SymbolPath {
    pub token: Token,
    pub stamp_ns: u64,
    /// Raw image points, px.
    pub points_px: Vec<[f64; 2]>,
}

/// The action (and unknown) tokens of one observer, each with its track samples.
pub fn symbol_paths(tokens: &[TokenEvent], track: &[TrackSample]) -> Vec<SymbolPath> {
    let mut out = Vec::new();
    for (i, t) in tokens.iter().enumerate() {
        if t.token == Token::Null {
            continue;
        }
        // The NULL confirmed before this symbol (tokens of a pair share a stamp).
        let from_ns = tokens[..i]
            .iter()
            .rev()
            .find(|p| p.token == Token::Null && p.confirmed_ns < t.confirmed_ns)
            .map(|p| p.confirmed_ns);
        let Some(from_ns) = from_ns else {
            continue;
        };
        let points_px = track
            .iter()
            .filter(|s| s.stamp_ns > from_ns && s.stamp_ns <= t.confirmed_ns)
            .filter_map(|s| s.pos_px)
            .collect();
        out.push(SymbolPath {
            token: t.token,
            stamp_ns: t.confirmed_ns,
            points_px,
        });
    }
    out
}

/// One panel, px (square; a caption strip of [`CAPTION_PX`] below).
const PANEL: u32 = 150;
const CAPTION_PX: u32 = 30;
const COLS: usize = 8;
/// The title strip above the panels, px.
const TOP_PX: u32 = 50;

/// The figure of one observer, or `None` when it published no track.
pub fn trajectories_svg(title: &str, rec: &ObserverRecord) -> Result<Option<String>> {
    if rec.track.is_empty() {
        return Ok(None);
    }
    let paths = symbol_paths(&rec.tokens, &rec.track);
    let rows = paths.len().div_ceil(COLS).max(1);
    let width = COLS as u32 * PANEL + 20;
    let height = TOP_PX + rows as u32 * (PANEL + CAPTION_PX) + 20;
    let mut doc = String::new();
    {
        let root = SVGBackend::with_string(&mut doc, (width, height)).into_drawing_area();
        root.fill(&WHITE)?;
        root.draw(&Text::new(
            title,
            (10, 18),
            text_style(14, &BLACK, HPos::Left),
        ))?;
        root.draw(&Text::new(
            "grey dashed: template of the decoded action (of the nearest one for an unknown); \
             colour: the observer's track, normalised as the matcher does (y down); E = RMS \
             error to that template",
            (10, 38),
            text_style(10, &hex(0x444444), HPos::Left),
        ))?;
        let grid = root.margin(TOP_PX, 20, 10, 10);
        if paths.is_empty() {
            grid.draw(&Text::new(
                "no symbol decoded",
                (0, 20),
                text_style(11, &BLACK, HPos::Left),
            ))?;
        }
        let panels = grid.split_evenly((rows, COLS));
        for (p, panel) in paths.iter().zip(&panels) {
            draw_panel(panel, p)?;
        }
        root.present()?;
    }
    Ok(Some(doc))
}

/// One symbol: its normalised track over its template, its time, token and error.
fn draw_panel(panel: &DrawingArea<SVGBackend<'_>, Shift>, p: &SymbolPath) -> Result<()> {
    let normalised = normalise(&resample_arc_length(&p.points_px, RESAMPLE_POINTS));
    let errors = (p.points_px.len() >= 2).then(|| template_errors(&p.points_px));
    let action = p.token.action().or_else(|| {
        errors.map(|e| {
            let best = (0..4).min_by(|&a, &b| e[a].total_cmp(&e[b])).unwrap_or(0);
            Action::ALL[best]
        })
    });
    let tpl: Vec<[f64; 2]> = action.map(|a| template(a).to_vec()).unwrap_or_default();
    let centre = (PANEL as i32 / 2, 0);
    panel.draw(&Rectangle::new(
        [(5, 5), (PANEL as i32 - 5, PANEL as i32 - 5)],
        hex(0xcccccc),
    ))?;
    let err = match (errors, action) {
        (Some(e), Some(a)) => format!(" E={:.3}", e[a.index()]),
        _ => String::new(),
    };
    let caption = text_style(10, &BLACK, HPos::Center);
    panel.draw(&Text::new(
        format!("{:.2} s {}{err}", ns_s(p.stamp_ns), p.token.label()),
        (centre.0, PANEL as i32 + 6),
        caption,
    ))?;
    panel.draw(&Text::new(
        format!("{} samples", p.points_px.len()),
        (centre.0, PANEL as i32 + 19),
        text_style(9, &hex(0x666666), HPos::Center),
    ))?;
    // Both drawn in the same unit box, placed to fit the union of their extents; y down.
    let all: Vec<[f64; 2]> = tpl.iter().chain(&normalised).copied().collect();
    if all.is_empty() {
        return Ok(());
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for q in &all {
        for d in 0..2 {
            lo[d] = lo[d].min(q[d]);
            hi[d] = hi[d].max(q[d]);
        }
    }
    let half = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-9) / 2.0;
    let (cx, cy) = ((lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0);
    let inner = panel.margin(15, CAPTION_PX as i32 + 15, 15, 15);
    let mut chart = ChartBuilder::on(&inner)
        .build_cartesian_2d((cx - half)..(cx + half), (-cy - half)..(-cy + half))?;
    let flip = |q: &[f64; 2]| (q[0], -q[1]);
    chart.draw_series(DashedLineSeries::new(
        tpl.iter().map(flip),
        4,
        3,
        hex(0x888888).stroke_width(2),
    ))?;
    let colour = p.token.action().map_or(BLACK, action_colour);
    chart.draw_series(LineSeries::new(normalised.iter().map(flip), colour))?;
    chart.draw_series(
        normalised
            .first()
            .map(|q| Circle::new(flip(q), 2, colour.filled())),
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::ObserverId;

    fn tok(seq: u64, token: Token, s: u64) -> TokenEvent {
        TokenEvent {
            observer: ObserverId::new("O1").unwrap(),
            seq,
            token,
            confirmed_ns: s,
        }
    }

    #[test]
    fn a_symbol_gets_the_samples_between_the_previous_null_and_its_confirmation() {
        let tokens = [
            tok(0, Token::Null, 10),
            tok(1, Token::Start, 20),
            tok(2, Token::Null, 20),
            tok(3, Token::Bit0, 30),
            tok(4, Token::Null, 30),
        ];
        let track: Vec<TrackSample> = (5..=30)
            .map(|s| TrackSample {
                stamp_ns: s,
                pos_px: (s != 15).then_some([s as f64, 0.0]),
            })
            .collect();
        let paths = symbol_paths(&tokens, &track);
        assert_eq!(paths.len(), 2);
        assert_eq!(paths[0].token, Token::Start);
        assert_eq!(
            paths[0].points_px.len(),
            9,
            "11..=20 without the lost sample"
        );
        assert_eq!(paths[1].points_px.first(), Some(&[21.0, 0.0]));
        assert_eq!(paths[1].points_px.last(), Some(&[30.0, 0.0]));
    }
}
