//! The paper's published values (Table "Final functional cases" and Table "Timing in the nominal
//! three-observer missions"), printed beside ours. Never used to judge a run: the case files'
//! `[expected]` outcomes do that.

/// One row of the paper's functional-case table for one modality.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PaperCase {
    pub messages: &'static str,
    pub work_units: u32,
    pub time_s: f64,
}

/// (case name, paper row label, RGB, events); `None` = the paper ran no such run ("—").
pub const CASES: &[(&str, &str, Option<PaperCase>, Option<PaperCase>)] = &[
    (
        "one-observer",
        "1 observer",
        Some(PaperCase {
            messages: "4",
            work_units: 2,
            time_s: 451.56,
        }),
        Some(PaperCase {
            messages: "4",
            work_units: 2,
            time_s: 475.16,
        }),
    ),
    (
        "two-observers",
        "2 observers",
        Some(PaperCase {
            messages: "4/4",
            work_units: 4,
            time_s: 463.16,
        }),
        Some(PaperCase {
            messages: "4/4",
            work_units: 4,
            time_s: 486.76,
        }),
    ),
    (
        "nominal-3",
        "3 observers",
        Some(PaperCase {
            messages: "4/4/4",
            work_units: 6,
            time_s: 493.80,
        }),
        Some(PaperCase {
            messages: "4/4/4",
            work_units: 6,
            time_s: 517.40,
        }),
    ),
    (
        "black-o2",
        "O2 black input",
        Some(PaperCase {
            messages: "4/0/4",
            work_units: 4,
            time_s: 454.48,
        }),
        Some(PaperCase {
            messages: "4/0/4",
            work_units: 4,
            time_s: 478.08,
        }),
    ),
    (
        "no-broadcast",
        "No broadcast",
        Some(PaperCase {
            messages: "0/0/0",
            work_units: 0,
            time_s: 15.04,
        }),
        Some(PaperCase {
            messages: "0/0/0",
            work_units: 0,
            time_s: 15.04,
        }),
    ),
    (
        "only-a",
        "Only offer A",
        Some(PaperCase {
            messages: "1/1/1",
            work_units: 0,
            time_s: 122.92,
        }),
        Some(PaperCase {
            messages: "1/1/1",
            work_units: 0,
            time_s: 134.76,
        }),
    ),
    (
        "dropout-o2",
        "O2 stream dropout",
        None,
        Some(PaperCase {
            messages: "4/0/4",
            work_units: 4,
            time_s: 478.08,
        }),
    ),
];

/// The paper's row for `case` in `modality` (`rgb` / `events`), and its row label.
pub fn case(case: &str, modality: &str) -> (Option<&'static str>, Option<PaperCase>) {
    match CASES.iter().find(|c| c.0 == case) {
        Some((_, label, rgb, events)) => {
            (Some(label), if modality == "rgb" { *rgb } else { *events })
        }
        None => (None, None),
    }
}

/// The paper's nominal timing table, (RGB, events), simulation seconds.
pub struct PaperTiming {
    pub first_offer_start_s: f64,
    pub offer_to_final_null_range_s: (f64, f64),
    pub offer_to_final_null_mean_s: f64,
    pub latest_final_reception_s: f64,
    pub latest_reception_to_completion_s: f64,
    pub total_s: f64,
}

pub const TIMING_RGB: PaperTiming = PaperTiming {
    first_offer_start_s: 5.002,
    offer_to_final_null_range_s: (95.570, 95.638),
    offer_to_final_null_mean_s: 95.600,
    latest_final_reception_s: 448.000,
    latest_reception_to_completion_s: 45.800,
    total_s: 493.800,
};

pub const TIMING_EVENTS: PaperTiming = PaperTiming {
    first_offer_start_s: 16.850,
    offer_to_final_null_range_s: (95.520, 95.590),
    offer_to_final_null_mean_s: 95.548,
    latest_final_reception_s: 471.600,
    latest_reception_to_completion_s: 45.800,
    total_s: 517.400,
};

#[cfg(test)]
mod tests {
    use super::*;
    use proto::Receiver;
    use run_format::case::{BUILT_IN, Case, PAPER_CASES};

    /// The case files' expected outcomes agree with the paper's table wherever the paper has a
    /// run, and each case applies to exactly the modalities the paper ran it in.
    #[test]
    fn case_files_agree_with_the_paper_table() {
        assert_eq!(CASES.len(), PAPER_CASES.len());
        for name in PAPER_CASES {
            assert!(BUILT_IN.iter().any(|(n, _)| n == name), "{name}");
            let c = Case::load(name).unwrap();
            for (m, cm) in [("rgb", Receiver::Rgb), ("events", Receiver::Events)] {
                let (_, paper) = case(name, m);
                assert_eq!(paper.is_some(), c.modalities.contains(&cm), "{name} {m}");
                if let Some(p) = paper {
                    let ours: Vec<String> =
                        c.expected.messages.iter().map(|n| n.to_string()).collect();
                    assert_eq!(ours.join("/"), p.messages, "{name} {m}");
                    assert_eq!(c.expected.work_units, p.work_units, "{name} {m}");
                    let served: usize = c.expected.services.values().map(Vec::len).sum();
                    assert_eq!(served as u32, p.work_units, "{name} services");
                }
            }
        }
    }
}
