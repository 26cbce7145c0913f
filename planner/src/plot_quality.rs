//! The anytime-quality figure of `planner quality --plot`: the mean gap to
//! the best-known score of each instance family against the deadline, on a
//! logarithmic deadline axis, so the curve of each family is visible.

use std::path::Path;

use plotters::prelude::*;

use crate::plot::{PALETTE, PlotError};

/// One family's curve: (deadline ms, mean gap %) points in deadline order.
pub struct GapCurve<'a> {
    /// Family name (legend).
    pub family: &'a str,
    /// The points.
    pub points: Vec<(f64, f64)>,
}

fn err(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError::Draw {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Writes the figure to `path` (SVG).
pub fn gap_curves(path: &Path, title: &str, curves: &[GapCurve<'_>]) -> Result<(), PlotError> {
    // Text is drawn with the embedded font only (no system fonts needed).
    crate::plot::register_font();
    let xs = curves.iter().flat_map(|c| c.points.iter().map(|p| p.0));
    let (lo, hi) = xs.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| (lo.min(x), hi.max(x)));
    if !(lo.is_finite() && hi > 0.0) {
        return Err(PlotError::Empty(path.display().to_string()));
    }
    let ymax = curves
        .iter()
        .flat_map(|c| c.points.iter().map(|p| p.1))
        .fold(0.0f64, f64::max)
        .max(0.5)
        * 1.1;
    let root = SVGBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(path, e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((lo * 0.8..hi * 1.25).log_scale(), 0.0..ymax)
        .map_err(|e| err(path, e))?;
    chart
        .configure_mesh()
        .x_desc("deadline (ms of thread CPU time, log scale)")
        .y_desc("mean gap to best known (%)")
        .draw()
        .map_err(|e| err(path, e))?;
    for (i, c) in curves.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        // Every sixth family dashes its line, so colours may repeat.
        let style = colour.stroke_width(if i >= PALETTE.len() { 1 } else { 2 });
        chart
            .draw_series(LineSeries::new(c.points.clone(), style))
            .map_err(|e| err(path, e))?
            .label(c.family)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
        chart
            .draw_series(c.points.iter().map(|&p| Circle::new(p, 3, colour.filled())))
            .map_err(|e| err(path, e))?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(path, e))?;
    root.present().map_err(|e| err(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_curves_and_refuses_an_empty_figure() {
        let dir = std::env::temp_dir().join(format!("plot-quality-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("q.svg");
        let curves = [GapCurve {
            family: "a",
            points: vec![(5.0, 3.0), (20.0, 1.0), (100.0, 0.2)],
        }];
        gap_curves(&path, "t", &curves).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        // plotters writes each label on a line of its own.
        assert!(
            svg.contains("<svg") && svg.lines().any(|l| l.trim() == "a"),
            "{}",
            &svg[..200.min(svg.len())]
        );
        assert!(matches!(gap_curves(&path, "t", &[]), Err(PlotError::Empty(_))));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
