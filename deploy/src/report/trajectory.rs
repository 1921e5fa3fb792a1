//! Per observer, the image-plane trajectory behind each decoded symbol over its template (SVG).
//!
//! The trajectory of a symbol is every track sample the observer published after the NULL
//! confirmation before it, up to the confirmation that classified it — the same span as the
//! receivers' own symbol trajectories. It is drawn as the matcher sees it: resampled to 80
//! arc-length points, first point subtracted, divided by the largest coordinate span.

use proto::alphabet::{RESAMPLE_POINTS, normalise, resample_arc_length, template, template_errors};
use proto::{Action, Token, TokenEvent, TrackSample};

use crate::report::svg::Svg;
use crate::report::timeline::action_colour;
use crate::run::ObserverRecord;
use crate::summary::ns_s;

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

const PANEL: f64 = 150.0;
const COLS: usize = 8;

/// The figure of one observer, or `None` when it published no track.
pub fn trajectories_svg(title: &str, rec: &ObserverRecord) -> Option<String> {
    if rec.track.is_empty() {
        return None;
    }
    let paths = symbol_paths(&rec.tokens, &rec.track);
    let rows = paths.len().div_ceil(COLS).max(1);
    let top = 50.0;
    let width = COLS as f64 * PANEL + 20.0;
    let height = top + rows as f64 * (PANEL + 30.0) + 20.0;
    let mut svg = Svg::new(width, height);
    svg.text(10.0, 20.0, 14.0, "start", "black", title);
    svg.text(
        10.0,
        38.0,
        10.0,
        "start",
        "#444444",
        "grey dashed: template of the decoded action (of the nearest one for an unknown); colour: \
         the observer's track, normalised as the matcher does (y down); E = RMS error to that template",
    );
    if paths.is_empty() {
        svg.text(
            10.0,
            top + 20.0,
            11.0,
            "start",
            "black",
            "no symbol decoded",
        );
    }
    for (k, p) in paths.iter().enumerate() {
        let (c, r) = (k % COLS, k / COLS);
        let x0 = 10.0 + c as f64 * PANEL;
        let y0 = top + r as f64 * (PANEL + 30.0);
        svg.frame(x0 + 5.0, y0 + 5.0, PANEL - 10.0, PANEL - 10.0, "#cccccc");
        let normalised = normalise(&resample_arc_length(&p.points_px, RESAMPLE_POINTS));
        let errors = if p.points_px.len() >= 2 {
            Some(template_errors(&p.points_px))
        } else {
            None
        };
        let action = p.token.action().or_else(|| {
            errors.map(|e| {
                let best = (0..4).min_by(|&a, &b| e[a].total_cmp(&e[b])).unwrap_or(0);
                Action::ALL[best]
            })
        });
        // Both drawn in the same unit box, placed to fit the union of their extents.
        let tpl: Vec<[f64; 2]> = action.map(|a| template(a).to_vec()).unwrap_or_default();
        let all: Vec<[f64; 2]> = tpl.iter().chain(&normalised).copied().collect();
        if all.is_empty() {
            continue;
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for q in &all {
            for d in 0..2 {
                lo[d] = lo[d].min(q[d]);
                hi[d] = hi[d].max(q[d]);
            }
        }
        let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-9);
        let inner = PANEL - 30.0;
        let map = |q: &[f64; 2]| -> [f64; 2] {
            let cx = (lo[0] + hi[0]) / 2.0;
            let cy = (lo[1] + hi[1]) / 2.0;
            [
                x0 + PANEL / 2.0 + (q[0] - cx) / span * inner,
                y0 + PANEL / 2.0 + (q[1] - cy) / span * inner,
            ]
        };
        let tpl_px: Vec<[f64; 2]> = tpl.iter().map(map).collect();
        svg.polyline(&tpl_px, "#888888", 2.0, Some("4 3"));
        let colour = p.token.action().map_or("#000000", action_colour);
        let path_px: Vec<[f64; 2]> = normalised.iter().map(map).collect();
        svg.polyline(&path_px, colour, 1.5, None);
        if let Some(first) = path_px.first() {
            svg.circle(first[0], first[1], 2.5, colour, Some("start of the path"));
        }
        let err = match (errors, action) {
            (Some(e), Some(a)) => format!(" E={:.3}", e[a.index()]),
            _ => String::new(),
        };
        svg.text(
            x0 + PANEL / 2.0,
            y0 + PANEL + 4.0,
            10.0,
            "middle",
            "black",
            &format!("{:.2} s {}{err}", ns_s(p.stamp_ns), p.token.label()),
        );
        svg.text(
            x0 + PANEL / 2.0,
            y0 + PANEL + 17.0,
            9.0,
            "middle",
            "#666666",
            &format!("{} samples", p.points_px.len()),
        );
    }
    Some(svg.finish())
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
