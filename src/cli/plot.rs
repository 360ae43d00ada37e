//! The `rigid bench --plot` chart: time per step against actor count, log–log, one line per
//! system and one for the whole step, drawn with plotters' SVG backend.

use crate::cli::bench::BenchResult;
use plotters::prelude::*;
use std::path::Path;

/// Draws `results` (at least two actor counts make lines; one makes points) into an SVG file.
pub fn plot_svg(path: &Path, results: &[BenchResult]) -> Result<(), String> {
    let fail = |e: &dyn std::fmt::Display| e.to_string();
    let mut series: Vec<(String, Vec<(f64, f64)>)> = vec![("step".into(), Vec::new())];
    for r in results {
        series[0].1.push((f64::from(r.actors), r.mean_ms_per_step));
        for (name, ms) in &r.systems_ms {
            match series.iter_mut().find(|(n, _)| n == name) {
                Some((_, points)) => points.push((f64::from(r.actors), *ms)),
                None => series.push((name.clone(), vec![(f64::from(r.actors), *ms)])),
            }
        }
    }
    let positive = |v: f64| v.max(1e-4);
    let (x_lo, x_hi) = bounds(results.iter().map(|r| f64::from(r.actors)));
    let (y_lo, y_hi) = bounds(series.iter().flat_map(|(_, p)| p.iter().map(|&(_, y)| positive(y))));
    let root = SVGBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("rigid bench {}: time per step", results.first().map_or("", |r| r.scene)), ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((x_lo / 1.5..x_hi * 1.5).log_scale(), (y_lo / 1.5..y_hi * 1.5).log_scale())
        .map_err(|e| fail(&e))?;
    chart.configure_mesh().x_desc("actors").y_desc("ms per step").draw().map_err(|e| fail(&e))?;
    for (k, (name, points)) in series.iter().enumerate() {
        let colour = Palette99::pick(k).stroke_width(if k == 0 { 3 } else { 1 });
        let points: Vec<(f64, f64)> = points.iter().map(|&(x, y)| (x, positive(y))).collect();
        chart
            .draw_series(LineSeries::new(points.clone(), colour))
            .map_err(|e| fail(&e))?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], Palette99::pick(k)));
        chart
            .draw_series(points.iter().map(|&p| Circle::new(p, 3, Palette99::pick(k).filled())))
            .map_err(|e| fail(&e))?;
    }
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw().map_err(|e| fail(&e))?;
    root.present().map_err(|e| fail(&e))
}

fn bounds(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if lo.is_finite() { (lo, hi.max(lo * 1.01)) } else { (1.0, 10.0) }
}
