//! The session timeline (SVG): symbols the performer flew, reception windows, and per observer
//! the tokens it confirmed, the frames it released, its decisions, its flights and site stays.

use proto::{Action, PerformerActivity, SessionEvent, Token};

use crate::report::audit::RunFiles;
use crate::report::svg::Svg;
use crate::summary::{decision_label, ns_s};

const LEFT: f64 = 120.0;
const RIGHT: f64 = 20.0;
const WIDTH: f64 = 1500.0;
const ROW: f64 = 26.0;

pub fn action_colour(a: Action) -> &'static str {
    match a {
        Action::Start => "#1f77b4",
        Action::Bit0 => "#2ca02c",
        Action::Bit1 => "#d62728",
        Action::End => "#9467bd",
    }
}

fn token_colour(t: Token) -> &'static str {
    match t.action() {
        Some(a) => action_colour(a),
        None if t == Token::Null => "#999999",
        None => "#000000",
    }
}

/// The timeline of one run as an SVG document.
pub fn timeline_svg(f: &RunFiles) -> String {
    let m = &f.summary.mission;
    let end_s = m.mission_time_s.max(1.0);
    let observers: Vec<&String> = f.observers.keys().collect();
    let rows = 2 + observers.len() * 2;
    let top = 40.0;
    let height = top + rows as f64 * ROW + 90.0;
    let mut svg = Svg::new(WIDTH, height);
    let x = |t_s: f64| LEFT + (WIDTH - LEFT - RIGHT) * (t_s / end_s).clamp(0.0, 1.0);
    svg.text(
        LEFT,
        20.0,
        14.0,
        "start",
        "black",
        &format!(
            "{} ({}) — session timeline, sim time 0–{:.2} s",
            m.case, m.modality, m.mission_time_s
        ),
    );
    let row_y = |r: usize| top + r as f64 * ROW;
    let labels: Vec<String> = ["performer".to_string(), "windows".to_string()]
        .into_iter()
        .chain(
            observers
                .iter()
                .flat_map(|o| [format!("{o} tokens"), format!("{o} flights")]),
        )
        .collect();
    for (r, l) in labels.iter().enumerate() {
        if r % 2 == 0 {
            svg.rect(0.0, row_y(r), WIDTH, ROW, "#f6f6f6", None);
        }
        svg.text(8.0, row_y(r) + ROW * 0.65, 11.0, "start", "black", l);
    }
    // Time axis.
    let axis_y = row_y(rows) + 4.0;
    svg.line(x(0.0), axis_y, x(end_s), axis_y, "black", 1.0);
    let step = if end_s > 200.0 {
        50.0
    } else if end_s > 40.0 {
        10.0
    } else {
        2.0
    };
    let mut t = 0.0;
    while t <= end_s + 1e-9 {
        svg.line(x(t), axis_y, x(t), axis_y + 5.0, "black", 1.0);
        svg.text(
            x(t),
            axis_y + 17.0,
            10.0,
            "middle",
            "black",
            &format!("{t:.0}"),
        );
        t += step;
    }
    svg.text(
        x(end_s),
        axis_y + 30.0,
        10.0,
        "end",
        "black",
        "sim time (s)",
    );

    match &f.session {
        Some(session) => {
            let y = row_y(0);
            for sp in &session.performer {
                let colour = match sp.activity {
                    PerformerActivity::Idle => continue,
                    PerformerActivity::Acquisition => "#777777",
                    PerformerActivity::NullHover => "#dddddd",
                    PerformerActivity::Action(a) => action_colour(a),
                };
                let title = format!(
                    "{:?} {:.2}–{:.2} s, round {}{}",
                    sp.activity,
                    ns_s(sp.start_ns),
                    ns_s(sp.end_ns),
                    sp.round,
                    sp.offer_bits
                        .as_ref()
                        .map_or(String::new(), |b| format!(", offer {b}"))
                );
                let (x0, x1) = (x(ns_s(sp.start_ns)), x(ns_s(sp.end_ns)));
                svg.rect(x0, y + 4.0, x1 - x0, ROW - 8.0, colour, Some(&title));
            }
            let y = row_y(1);
            let mut open: Option<(u32, u64)> = None;
            for c in &session.controls {
                match c.event {
                    SessionEvent::WindowOpen { round } => open = Some((round, c.stamp_ns)),
                    SessionEvent::WindowClose { round } => {
                        if let Some((r, from)) = open.take() {
                            let (x0, x1) = (x(ns_s(from)), x(ns_s(c.stamp_ns)));
                            let title = format!(
                                "round {round} reception window {:.2}–{:.2} s",
                                ns_s(from),
                                ns_s(c.stamp_ns)
                            );
                            svg.rect(x0, y + 4.0, x1 - x0, ROW - 8.0, "#aec7e8", Some(&title));
                            svg.text(
                                x0 + 3.0,
                                y + ROW * 0.65,
                                10.0,
                                "start",
                                "black",
                                &format!("round {r}"),
                            );
                        }
                    }
                    SessionEvent::RoundReset { .. } | SessionEvent::MissionEnd => {
                        let xc = x(ns_s(c.stamp_ns));
                        svg.line(xc, y + 2.0, xc, y + ROW - 2.0, "#333333", 1.0);
                    }
                }
            }
            if let Some((r, from)) = open {
                let (x0, x1) = (x(ns_s(from)), x(end_s));
                svg.rect(x0, y + 4.0, x1 - x0, ROW - 8.0, "#aec7e8", None);
                svg.text(
                    x0 + 3.0,
                    y + ROW * 0.65,
                    10.0,
                    "start",
                    "black",
                    &format!("round {r}"),
                );
            }
        }
        None => svg.text(
            LEFT + 4.0,
            row_y(0) + ROW * 0.65,
            11.0,
            "start",
            "#aa0000",
            "no session.json in this run directory: performer, windows and flights not recorded",
        ),
    }

    for (k, o) in observers.iter().enumerate() {
        let rec = &f.observers[*o];
        let y = row_y(2 + 2 * k);
        for t in &rec.tokens {
            let xt = x(ns_s(t.confirmed_ns));
            let tall = t.token != Token::Null;
            let (y0, y1) = if tall {
                (y + 3.0, y + ROW - 3.0)
            } else {
                (y + 9.0, y + ROW - 9.0)
            };
            svg.line(
                xt,
                y0,
                xt,
                y1,
                token_colour(t.token),
                if tall { 2.0 } else { 1.0 },
            );
        }
        for fe in &rec.frames {
            let xt = x(ns_s(fe.frame.final_null_ns()));
            svg.circle(
                xt,
                y + ROW / 2.0,
                4.0,
                "#ff7f0e",
                Some(&format!(
                    "frame {:06b} released at {:.2} s (round {})",
                    fe.frame.payload,
                    ns_s(fe.frame.final_null_ns()),
                    fe.round
                )),
            );
        }
        for d in &rec.decisions {
            let xt = x(ns_s(d.decided_ns));
            svg.text(
                xt + 5.0,
                y + 10.0,
                10.0,
                "start",
                "black",
                &decision_label(d),
            );
        }
        let y = row_y(3 + 2 * k);
        if let Some(session) = &f.session {
            for trip in session.trips.iter().filter(|t| &&t.observer == o) {
                let back = trip.back_ns.map_or(end_s, ns_s);
                let (x0, x1) = (x(ns_s(trip.leave_ns)), x(back));
                let title = format!("away from home {:.2}–{back:.2} s", ns_s(trip.leave_ns));
                svg.rect(x0, y + 6.0, x1 - x0, ROW - 12.0, "#fdd0a2", Some(&title));
            }
            for st in session.stays.iter().filter(|s| &&s.observer == o) {
                let leave = st.leave_ns.map_or(end_s, ns_s);
                let (x0, x1) = (x(ns_s(st.arrive_ns)), x(leave));
                let title = format!("at site {} {:.2}–{leave:.2} s", st.site, ns_s(st.arrive_ns));
                svg.rect(x0, y + 3.0, x1 - x0, ROW - 6.0, "#d94801", Some(&title));
                svg.text(
                    x1 + 2.0,
                    y + ROW * 0.65,
                    10.0,
                    "start",
                    "black",
                    st.site.name(),
                );
            }
            if let Some(report) = &session.report {
                for dep in report
                    .departures
                    .iter()
                    .filter(|d| d.observer.as_str() == o.as_str())
                {
                    let xd = x(ns_s(dep.t_ns));
                    svg.line(xd, y + 1.0, xd, y + ROW - 1.0, "black", 1.5);
                }
            }
        }
    }

    // Legend.
    let ly = axis_y + 45.0;
    let mut lx = LEFT;
    let mut key = |svg: &mut Svg, colour: &str, label: &str| {
        svg.rect(lx, ly - 9.0, 14.0, 10.0, colour, None);
        svg.text(lx + 18.0, ly, 10.0, "start", "black", label);
        lx += 26.0 + 6.5 * label.len() as f64;
    };
    key(&mut svg, "#777777", "acquisition");
    key(&mut svg, "#dddddd", "NULL hover / NULL token");
    for a in Action::ALL {
        key(&mut svg, action_colour(a), &format!("{a}"));
    }
    key(&mut svg, "#000000", "unknown");
    key(&mut svg, "#ff7f0e", "frame released");
    key(&mut svg, "#fdd0a2", "away from home");
    key(&mut svg, "#d94801", "at site (service)");
    svg.text(
        LEFT,
        ly + 18.0,
        10.0,
        "start",
        "#444444",
        "black ticks in the flights rows: the scheduler's departures; r<round>:<site> labels: decisions. \
         Hover an element for its times.",
    );
    svg.finish()
}
