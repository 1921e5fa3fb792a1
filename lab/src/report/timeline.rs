//! The session timeline (SVG, drawn with `plotters`): symbols the performer flew, reception
//! windows, and per observer the tokens it confirmed, the frames it released, its decisions,
//! its flights and site stays, over sim time.

use anyhow::Result;
use plotters::prelude::*;
use plotters::style::text_anchor::HPos;
use proto::{Action, PerformerActivity, SessionEvent, Token};

use super::plot::{Chart, bar, hex, line, text_style};
use run_eval::summary::{decision_label, ns_s};
use run_format::run_dir::session::SessionRecord;
use run_format::run_dir::{ObserverRecord, RunFiles};

const WIDTH: u32 = 1500;
/// Height of one row, px.
const ROW_PX: u32 = 26;
/// Height of the legend under the chart, px.
const LEGEND_PX: u32 = 60;

const NULL_GREY: RGBColor = hex(0x999999);
const HOVER_GREY: RGBColor = hex(0xdddddd);
const ACQUISITION_GREY: RGBColor = hex(0x777777);
const WINDOW_BLUE: RGBColor = hex(0xaec7e8);
const FRAME_ORANGE: RGBColor = hex(0xff7f0e);
const AWAY_ORANGE: RGBColor = hex(0xfdd0a2);
const SITE_ORANGE: RGBColor = hex(0xd94801);
const STRIPE: RGBColor = hex(0xf6f6f6);

/// The colour of an action (also used by the symbol-trajectory figure).
pub fn action_colour(a: Action) -> RGBColor {
    match a {
        Action::Start => hex(0x1f77b4),
        Action::Bit0 => hex(0x2ca02c),
        Action::Bit1 => hex(0xd62728),
        Action::End => hex(0x9467bd),
    }
}

fn token_colour(t: Token) -> RGBColor {
    match t.action() {
        Some(a) => action_colour(a),
        None if t == Token::Null => NULL_GREY,
        None => BLACK,
    }
}

/// Rows from the top: the performer, the windows, then two per observer. Row `r` is centred
/// on `y = rows − 1 − r`, so the axis labels (at whole numbers) sit on the rows.
struct Rows {
    labels: Vec<String>,
}

impl Rows {
    fn centre(&self, r: usize) -> f64 {
        (self.labels.len() - 1 - r) as f64
    }

    fn label(&self, y: f64) -> String {
        let r = self.labels.len() as f64 - 1.0 - y;
        if (r - r.round()).abs() > 1e-6 || r < -0.5 {
            return String::new();
        }
        self.labels
            .get(r.round() as usize)
            .cloned()
            .unwrap_or_default()
    }
}

/// The timeline of one run as an SVG document.
pub fn timeline_svg(f: &RunFiles) -> Result<String> {
    let m = &f.summary.mission;
    let end_s = m.mission_time_s.max(1.0);
    let observers: Vec<&String> = f.observers.keys().collect();
    let rows = Rows {
        labels: ["performer".to_string(), "windows".to_string()]
            .into_iter()
            .chain(
                observers
                    .iter()
                    .flat_map(|o| [format!("{o} tokens"), format!("{o} flights")]),
            )
            .collect(),
    };
    let n = rows.labels.len();
    let height = 60 + n as u32 * ROW_PX + 50 + LEGEND_PX;
    let mut doc = String::new();
    {
        let root = SVGBackend::with_string(&mut doc, (WIDTH, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let (top, legend_area) = root.split_vertically(height - LEGEND_PX);
        let title = format!(
            "{} ({}) — session timeline, sim time 0–{:.2} s",
            m.case,
            run_eval::summary::receiver_text(m.modality),
            m.mission_time_s
        );
        let mut chart = ChartBuilder::on(&top)
            .caption(title, ("sans-serif", 15))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(110)
            .build_cartesian_2d(0.0..end_s, -0.5..n as f64 - 0.5)?;
        let label = |y: &f64| rows.label(*y);
        let seconds = |x: &f64| format!("{x:.0}");
        chart
            .configure_mesh()
            .disable_y_mesh()
            .y_labels(n)
            .y_label_formatter(&label)
            .x_label_formatter(&seconds)
            .x_desc("sim time (s)")
            .light_line_style(WHITE)
            .bold_line_style(hex(0xe0e0e0))
            .label_style(("sans-serif", 11))
            .draw()?;
        chart.draw_series((0..n).step_by(2).map(|r| {
            let c = rows.centre(r);
            bar(0.0, end_s, c - 0.5, c + 0.5, STRIPE)
        }))?;
        match &f.session {
            Some(session) => {
                draw_performer(&mut chart, session, rows.centre(0))?;
                draw_windows(&mut chart, session, rows.centre(1), end_s)?;
            }
            None => {
                chart.draw_series(std::iter::once(Text::new(
                    "no session.json in this run directory: performer, windows and flights not recorded",
                    (0.0, rows.centre(0)),
                    text_style(11, &hex(0xaa0000), HPos::Left),
                )))?;
            }
        }
        for (k, o) in observers.iter().enumerate() {
            draw_outputs(&mut chart, &f.observers[*o], rows.centre(2 + 2 * k))?;
            if let Some(session) = &f.session {
                draw_flights(&mut chart, session, o, rows.centre(3 + 2 * k), end_s)?;
            }
        }
        draw_legend(&legend_area)?;
        root.present()?;
    }
    Ok(doc)
}

/// The performer row: one bar per flown span (idle left out).
fn draw_performer(chart: &mut Chart<'_, '_>, session: &SessionRecord, y: f64) -> Result<()> {
    let bars = session.performer.iter().filter_map(|sp| {
        let colour = match sp.activity {
            PerformerActivity::Idle => return None,
            PerformerActivity::Acquisition => ACQUISITION_GREY,
            PerformerActivity::NullHover => HOVER_GREY,
            PerformerActivity::Action(a) => action_colour(a),
        };
        Some(bar(
            ns_s(sp.start_ns),
            ns_s(sp.end_ns),
            y - 0.35,
            y + 0.35,
            colour,
        ))
    });
    chart.draw_series(bars)?;
    Ok(())
}

/// The windows row: each reception window with its round; round resets and the mission end
/// as ticks.
fn draw_windows(
    chart: &mut Chart<'_, '_>,
    session: &SessionRecord,
    y: f64,
    end_s: f64,
) -> Result<()> {
    let mut windows: Vec<(u32, f64, f64)> = Vec::new();
    let mut ticks: Vec<f64> = Vec::new();
    let mut open: Option<(u32, u64)> = None;
    for c in &session.controls {
        match c.event {
            SessionEvent::WindowOpen { round } => open = Some((round, c.stamp_ns)),
            SessionEvent::WindowClose { .. } => {
                if let Some((r, from)) = open.take() {
                    windows.push((r, ns_s(from), ns_s(c.stamp_ns)));
                }
            }
            SessionEvent::RoundReset { .. } | SessionEvent::MissionEnd => {
                ticks.push(ns_s(c.stamp_ns));
            }
        }
    }
    if let Some((r, from)) = open {
        windows.push((r, ns_s(from), end_s));
    }
    chart.draw_series(
        windows
            .iter()
            .map(|(_, x0, x1)| bar(*x0, *x1, y - 0.35, y + 0.35, WINDOW_BLUE)),
    )?;
    chart.draw_series(windows.iter().map(|(r, x0, _)| {
        Text::new(
            format!(" round {r}"),
            (*x0, y),
            text_style(10, &BLACK, HPos::Left),
        )
    }))?;
    chart.draw_series(
        ticks
            .iter()
            .map(|x| line((*x, y - 0.45), (*x, y + 0.45), hex(0x333333), 1)),
    )?;
    Ok(())
}

/// An observer's tokens row: its confirmed tokens (actions tall, NULLs short), released
/// frames and decisions.
fn draw_outputs(chart: &mut Chart<'_, '_>, rec: &ObserverRecord, y: f64) -> Result<()> {
    chart.draw_series(rec.tokens.iter().map(|t| {
        let x = ns_s(t.confirmed_ns);
        let tall = t.token != Token::Null;
        let h = if tall { 0.38 } else { 0.15 };
        line(
            (x, y - h),
            (x, y + h),
            token_colour(t.token),
            if tall { 2 } else { 1 },
        )
    }))?;
    chart.draw_series(rec.frames.iter().map(|fe| {
        Circle::new(
            (ns_s(fe.frame.final_null_ns()), y),
            4,
            FRAME_ORANGE.filled(),
        )
    }))?;
    chart.draw_series(rec.decisions.iter().map(|d| {
        Text::new(
            format!("  {}", decision_label(d)),
            (ns_s(d.decided_ns), y + 0.25),
            text_style(10, &BLACK, HPos::Left),
        )
    }))?;
    Ok(())
}

/// An observer's flights row: trips away from home, stays at a site, the scheduler's
/// departures.
fn draw_flights(
    chart: &mut Chart<'_, '_>,
    session: &SessionRecord,
    o: &str,
    y: f64,
    end_s: f64,
) -> Result<()> {
    chart.draw_series(session.trips.iter().filter(|t| t.observer == o).map(|t| {
        let back = t.back_ns.map_or(end_s, ns_s);
        bar(ns_s(t.leave_ns), back, y - 0.27, y + 0.27, AWAY_ORANGE)
    }))?;
    let stays: Vec<_> = session.stays.iter().filter(|s| s.observer == o).collect();
    chart.draw_series(stays.iter().map(|st| {
        let leave = st.leave_ns.map_or(end_s, ns_s);
        bar(ns_s(st.arrive_ns), leave, y - 0.38, y + 0.38, SITE_ORANGE)
    }))?;
    chart.draw_series(stays.iter().map(|st| {
        Text::new(
            format!(" {}", st.site.name()),
            (st.leave_ns.map_or(end_s, ns_s), y),
            text_style(10, &BLACK, HPos::Left),
        )
    }))?;
    if let Some(report) = &session.report {
        chart.draw_series(
            report
                .departures
                .iter()
                .filter(|d| d.observer.as_str() == o)
                .map(|d| {
                    let x = ns_s(d.t_ns);
                    line((x, y - 0.48), (x, y + 0.48), BLACK, 2)
                }),
        )?;
    }
    Ok(())
}

/// The colour key and the reading notes, in pixel coordinates.
fn draw_legend(area: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>) -> Result<()> {
    let mut keys: Vec<(RGBColor, String)> = vec![
        (ACQUISITION_GREY, "acquisition".into()),
        (HOVER_GREY, "NULL hover / NULL token".into()),
    ];
    keys.extend(Action::ALL.map(|a| (action_colour(a), a.to_string())));
    keys.extend([
        (BLACK, "unknown".to_string()),
        (FRAME_ORANGE, "frame released".into()),
        (AWAY_ORANGE, "away from home".into()),
        (SITE_ORANGE, "at site (service)".into()),
    ]);
    let mut x = 120;
    for (colour, label) in &keys {
        area.draw(&Rectangle::new([(x, 10), (x + 14, 20)], colour.filled()))?;
        area.draw(&Text::new(
            label.as_str(),
            (x + 18, 15),
            text_style(10, &BLACK, HPos::Left),
        ))?;
        x += 26 + (6.5 * label.len() as f64) as i32;
    }
    area.draw(&Text::new(
        "black ticks in the flights rows: the scheduler's departures; r<round>:<site> labels: \
         decisions; grey NULL ticks are short, action ticks tall.",
        (120, 38),
        text_style(10, &hex(0x444444), HPos::Left),
    ))?;
    Ok(())
}
