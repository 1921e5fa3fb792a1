//! A study's figure: the success probability with its 95 % interval against the levels of one
//! condition, a series per modality or arm (SVG, drawn with `plotters`).

use anyhow::Result;

use crate::harness::study::vary::Vary;
use run_format::study_file::level_text;

/// One measured point of a series.
#[derive(Debug, Clone, PartialEq)]
pub struct FigurePoint {
    pub series: String,
    pub level: f64,
    pub success_rate: Option<f64>,
    pub ci95: [f64; 2],
}

/// The success probability with its interval against the levels of `vary`, one series per
/// name in `series`, titled by `name`.
pub fn success_figure(
    name: &str,
    series: &[String],
    vary: &Vary,
    points: &[FigurePoint],
) -> Result<String> {
    use plotters::prelude::*;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (720, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow::anyhow!("{e}"))?;
        // Levels are often geometric (0, 0.0003, 0.001, …): one evenly spaced slot per level,
        // labelled with its value, keeps every point readable.
        let levels = &vary.levels;
        let slot = |level: f64| levels.iter().position(|&l| l == level).unwrap_or(0) as f64;
        let n = levels.len() as f64;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("{name}: P(success) ± 95 % CI against {}", vary.key),
                ("sans-serif", 18),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(-0.5..n - 0.5, 0.0..1.05)
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        chart
            .configure_mesh()
            .x_labels(levels.len())
            .x_label_formatter(&|x| {
                let k = x.round();
                levels
                    .get(k as usize)
                    .filter(|_| (x - k).abs() < 1e-6 && k >= 0.0)
                    .map_or(String::new(), |l| level_text(&vary.key, *l))
            })
            .x_desc(vary.key.as_str())
            .y_desc("P(success)")
            .draw()
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        for (k, m) in series.iter().enumerate() {
            let colour = Palette99::pick(k).to_rgba();
            let m = m.clone();
            let pts: Vec<&FigurePoint> = points.iter().filter(|r| r.series == m).collect();
            chart
                .draw_series(LineSeries::new(
                    pts.iter()
                        .filter_map(|r| r.success_rate.map(|p| (slot(r.level), p))),
                    colour.stroke_width(2),
                ))
                .map_err(|e| anyhow::anyhow!("{e}"))?
                .label(m.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(pts.iter().map(|r| {
                    PathElement::new(
                        vec![(slot(r.level), r.ci95[0]), (slot(r.level), r.ci95[1])],
                        colour.stroke_width(1),
                    )
                }))
                .map_err(|e| anyhow::anyhow!("{e}"))?;
        }
        chart
            .configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE)
            .draw()
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        root.present().map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    Ok(svg)
}
