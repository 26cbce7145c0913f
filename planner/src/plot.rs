//! Figures as SVG (plotters, no fonts needed): per-run comparison panels
//! (the analogues of the paper's Fig. 4–7) and the network map (Fig. 8 and
//! the mission plot): the chart's land and water, the waypoints, the dynamic
//! waypoints' bounds, routes and event markers.
//!
//! Contract: functions here only draw what they are given; they compute no
//! statistics and know nothing of solvers or transport. Coordinates are the
//! planner frame (x east, y north, metres).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use auv_world::chart::WaterMap;

/// Why a figure could not be written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The drawing backend failed (usually the file could not be written).
    #[error("cannot draw {path}: {message}")]
    Draw {
        /// The figure's path.
        path: String,
        /// What the backend said.
        message: String,
    },
    /// Nothing to draw.
    #[error("cannot draw {0}: no data")]
    Empty(String),
}

/// One line of a per-run panel: a label and a value per run.
pub struct Series<'a> {
    /// Legend label (e.g. the algorithm).
    pub label: &'a str,
    /// One value per run, in run order.
    pub values: &'a [f64],
}

/// One panel of a per-run figure.
pub struct Panel<'a> {
    /// Y axis label with its unit.
    pub y_label: &'a str,
    /// The lines to draw.
    pub series: &'a [Series<'a>],
}

/// Colours of successive series / routes: distinguishable, print-friendly.
pub(crate) const PALETTE: [RGBColor; 6] = [
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
];

/// Registers the embedded DejaVu Sans as "sans-serif" (once): plotters built
/// with `ab_glyph` measures and draws text only with registered fonts, on
/// every backend.
pub fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The embedded font always parses; a failure would surface as a
        // "font unavailable" drawing error naming the figure.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular());
    });
}

fn draw_err(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError::Draw {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Writes a figure of stacked per-run panels (x = run number) to `path`.
pub fn per_run_figure(path: &Path, title: &str, panels: &[Panel<'_>]) -> Result<(), PlotError> {
    if panels.is_empty() || panels.iter().all(|p| p.series.iter().all(|s| s.values.is_empty())) {
        return Err(PlotError::Empty(path.display().to_string()));
    }
    stacked_figure(path, title, 300, panels, draw_panel)
}

/// Writes `panels` one above the other, each `panel_height` px high, under
/// `title`, drawing each with `draw`.
fn stacked_figure<P>(
    path: &Path,
    title: &str,
    panel_height: u32,
    panels: &[P],
    draw: impl Fn(&DrawingArea<SVGBackend<'_>, Shift>, &P) -> Result<(), String>,
) -> Result<(), PlotError> {
    let height = 60 + panel_height * panels.len() as u32;
    register_font();
    let root = SVGBackend::new(path, (900, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| draw_err(path, e))?;
    let root = root.titled(title, ("sans-serif", 22)).map_err(|e| draw_err(path, e))?;
    let areas = root.split_evenly((panels.len(), 1));
    for (area, panel) in areas.iter().zip(panels) {
        draw(area, panel).map_err(|e| draw_err(path, e))?;
    }
    root.present().map_err(|e| draw_err(path, e))
}

fn draw_panel(area: &DrawingArea<SVGBackend<'_>, Shift>, panel: &Panel<'_>) -> Result<(), String> {
    let runs = panel.series.iter().map(|s| s.values.len()).max().unwrap_or(0).max(1);
    let finite = || {
        panel
            .series
            .iter()
            .flat_map(|s| s.values.iter().copied())
            .filter(|v| v.is_finite())
    };
    let lo = finite().fold(f64::INFINITY, f64::min);
    let hi = finite().fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = if lo.is_finite() { (lo, hi) } else { (0.0, 1.0) };
    let pad = ((hi - lo) * 0.05).max(hi.abs() * 1e-6).max(1e-9);
    let mut chart = ChartBuilder::on(area)
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(70)
        .build_cartesian_2d(1f64..runs as f64, (lo - pad)..(hi + pad))
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc("run")
        .y_desc(panel.y_label)
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(|e| e.to_string())?;
    for (i, s) in panel.series.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let points = s
            .values
            .iter()
            .enumerate()
            .filter(|(_, v)| v.is_finite())
            .map(|(k, &v)| ((k + 1) as f64, v));
        chart
            .draw_series(LineSeries::new(points, colour.stroke_width(1)))
            .map_err(|e| e.to_string())?
            .label(s.label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())
}

/// One line of an x–y panel: a label and its points (x ascending or not;
/// several points may share an x).
pub struct XySeries<'a> {
    /// Legend label.
    pub label: &'a str,
    /// (x, y) points.
    pub points: Vec<(f64, f64)>,
}

/// One panel of an x–y figure.
pub struct XyPanel<'a> {
    /// Y axis label with its unit.
    pub y_label: &'a str,
    /// The lines to draw.
    pub series: Vec<XySeries<'a>>,
}

/// Writes a figure of stacked x–y panels sharing the x axis `x_label`:
/// every point as a marker, each series' line through the mean of its
/// points at each x.
pub fn xy_figure(path: &Path, title: &str, x_label: &str, panels: &[XyPanel<'_>]) -> Result<(), PlotError> {
    let all = || {
        panels
            .iter()
            .flat_map(|p| p.series.iter().flat_map(|s| s.points.iter()))
    };
    if all().next().is_none() {
        return Err(PlotError::Empty(path.display().to_string()));
    }
    let x_hi = all().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
    stacked_figure(path, title, 260, panels, |area, panel| {
        draw_xy_panel(area, panel, x_label, x_hi * 1.05)
    })
}

fn draw_xy_panel(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    panel: &XyPanel<'_>,
    x_label: &str,
    x_hi: f64,
) -> Result<(), String> {
    let ys = || panel.series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
    let lo = ys().fold(0.0f64, f64::min);
    let hi = ys().fold(f64::NEG_INFINITY, f64::max);
    let hi = if hi > lo { hi } else { lo + 1.0 };
    let pad = (hi - lo) * 0.08;
    let mut chart = ChartBuilder::on(area)
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(70)
        .build_cartesian_2d(0f64..x_hi, lo..(hi + pad))
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(panel.y_label)
        .x_label_formatter(&|v| tick_label(*v))
        .y_label_formatter(&|v| tick_label(*v))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(|e| e.to_string())?;
    for (i, s) in panel.series.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let mut xs: Vec<f64> = s.points.iter().map(|p| p.0).collect();
        xs.sort_by(f64::total_cmp);
        xs.dedup();
        let means = xs.iter().map(|&x| {
            let at: Vec<f64> = s.points.iter().filter(|p| p.0 == x).map(|p| p.1).collect();
            (x, at.iter().sum::<f64>() / at.len() as f64)
        });
        chart
            .draw_series(LineSeries::new(means, colour.stroke_width(2)))
            .map_err(|e| e.to_string())?
            .label(s.label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
        chart
            .draw_series(s.points.iter().map(|&p| Circle::new(p, 3, colour.filled())))
            .map_err(|e| e.to_string())?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())
}

/// A dynamic waypoint's bound, drawn as an ellipse around its nominal
/// position with the per-axis bounds as semi-axes.
pub struct BoundMarker {
    /// Nominal position (x, y), m.
    pub nominal: (f64, f64),
    /// Bound along x and y, m.
    pub bound: (f64, f64),
}

/// A route to draw as a polyline through waypoint positions.
pub struct RouteLayer<'a> {
    /// Legend label.
    pub label: &'a str,
    /// Points in order (x, y), m.
    pub points: &'a [(f64, f64)],
    /// Dashed (e.g. a plan superseded by a re-plan) or solid.
    pub dashed: bool,
}

/// Everything the network map shows.
pub struct MapFigure<'a> {
    /// Title.
    pub title: &'a str,
    /// The chart (land/water).
    pub map: &'a dyn WaterMap,
    /// Waypoint positions (x, y), m, indexed by node id.
    pub waypoints: &'a [(f64, f64)],
    /// Start node id.
    pub start: usize,
    /// Goal node id.
    pub goal: usize,
    /// Bounds of the dynamic waypoints.
    pub bounds: &'a [BoundMarker],
    /// Routes, drawn in palette order.
    pub routes: &'a [RouteLayer<'a>],
    /// Event markers (e.g. where re-plans happened), (x, y), m.
    pub markers: &'a [(f64, f64)],
    /// Legend label of the markers.
    pub marker_label: &'a str,
}

/// Land colour and water colour of the map background.
const LAND: RGBColor = RGBColor(222, 206, 160);
const WATER: RGBColor = RGBColor(214, 232, 246);

/// Writes the network map to `path` (SVG).
pub fn map_figure(path: &Path, fig: &MapFigure<'_>) -> Result<(), PlotError> {
    map_panels(path, None, std::slice::from_ref(fig))
}

/// Writes maps side by side into one SVG (e.g. one per algorithm), under a
/// common `title` if given. Each map keeps its chart's aspect ratio.
pub fn map_panels(path: &Path, title: Option<&str>, figs: &[MapFigure<'_>]) -> Result<(), PlotError> {
    let Some(first) = figs.first() else {
        return Err(PlotError::Empty(path.display().to_string()));
    };
    let (w, h) = (first.map.width_m(), first.map.height_m());
    if !(w > 0.0 && h > 0.0) {
        return Err(PlotError::Empty(path.display().to_string()));
    }
    // Keep the chart's aspect ratio: the longer side gets 900 px.
    let scale = 900.0 / w.max(h);
    let panel = ((w * scale) as u32 + 110, (h * scale) as u32 + 90);
    let top = if title.is_some() { 40 } else { 0 };
    let size = (panel.0 * figs.len() as u32, panel.1 + top);
    register_font();
    let root = SVGBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(|e| draw_err(path, e))?;
    let root = match title {
        Some(t) => root.titled(t, ("sans-serif", 22)).map_err(|e| draw_err(path, e))?,
        None => root,
    };
    for (area, fig) in root.split_evenly((1, figs.len())).iter().zip(figs) {
        draw_map(area, fig).map_err(|e| draw_err(path, e))?;
    }
    root.present().map_err(|e| draw_err(path, e))
}

/// Draws one network map into `area`.
fn draw_map(area: &DrawingArea<SVGBackend<'_>, Shift>, fig: &MapFigure<'_>) -> Result<(), String> {
    let (w, h) = (fig.map.width_m(), fig.map.height_m());
    let mut chart = ChartBuilder::on(area)
        .caption(fig.title, ("sans-serif", 20))
        .margin(10)
        .margin_right(40)
        .x_label_area_size(36)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..w, 0.0..h)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("x east (m)")
        .y_desc("y north (m)")
        .draw()
        .map_err(|e| e.to_string())?;
    chart.plotting_area().fill(&WATER).map_err(|e| e.to_string())?;
    let cell = w.max(h) / 250.0;
    let land = land_cells(fig.map, 250)
        .into_iter()
        .map(|r| Rectangle::new(r, LAND.filled()));
    chart.draw_series(land).map_err(|e| e.to_string())?;

    let grey = RGBColor(90, 90, 90);
    chart
        .draw_series(fig.bounds.iter().map(|b| {
            let pts: Vec<(f64, f64)> = (0..=48)
                .map(|k| {
                    let t = std::f64::consts::TAU * k as f64 / 48.0;
                    (b.nominal.0 + b.bound.0 * t.cos(), b.nominal.1 + b.bound.1 * t.sin())
                })
                .collect();
            PathElement::new(pts, grey.stroke_width(1))
        }))
        .map_err(|e| e.to_string())?
        .label("dynamic bound")
        .legend(move |(x, y)| Circle::new((x + 10, y), 5, grey.stroke_width(1)));

    for (i, route) in fig.routes.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let style = colour.stroke_width(if route.dashed { 1 } else { 2 });
        let series: Vec<PathElement<(f64, f64)>> = if route.dashed {
            dashes(route.points, w.max(h) / 120.0)
                .into_iter()
                .map(|seg| PathElement::new(seg, style))
                .collect()
        } else {
            vec![PathElement::new(route.points.to_vec(), style)]
        };
        chart
            .draw_series(series)
            .map_err(|e| e.to_string())?
            .label(route.label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
    }

    chart
        .draw_series(
            fig.waypoints
                .iter()
                .enumerate()
                .filter(|&(i, _)| i != fig.start && i != fig.goal)
                .map(|(_, &p)| Circle::new(p, 3, BLACK.filled())),
        )
        .map_err(|e| e.to_string())?
        .label("waypoint")
        .legend(|(x, y)| Circle::new((x + 10, y), 3, BLACK.filled()));
    if !fig.markers.is_empty() {
        let orange = PALETTE[4];
        chart
            .draw_series(fig.markers.iter().map(|&p| TriangleMarker::new(p, 6, orange.filled())))
            .map_err(|e| e.to_string())?
            .label(fig.marker_label)
            .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 6, orange.filled()));
    }
    for (node, label, colour) in [(fig.start, "start", PALETTE[2]), (fig.goal, "goal", PALETTE[3])] {
        if let Some(&p) = fig.waypoints.get(node) {
            chart
                .draw_series([Rectangle::new(
                    [(p.0 - cell, p.1 - cell), (p.0 + cell, p.1 + cell)],
                    colour.filled(),
                )])
                .map_err(|e| e.to_string())?
                .label(label)
                .legend(move |(x, y)| Rectangle::new([(x + 5, y - 5), (x + 15, y + 5)], colour.filled()));
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())
}

/// Land as run-length rectangles ([(x0, y0), (x1, y1)], m) on a grid of
/// `cells` cells along the chart's longer side: readable, and keeps an SVG
/// small.
pub fn land_cells(map: &dyn WaterMap, cells: usize) -> Vec<[(f64, f64); 2]> {
    let (w, h) = (map.width_m(), map.height_m());
    let cell = w.max(h) / cells.max(1) as f64;
    let (cols, rows) = ((w / cell).ceil() as usize, (h / cell).ceil() as usize);
    let mut land = Vec::new();
    for r in 0..rows {
        let y0 = r as f64 * cell;
        let yc = (y0 + cell / 2.0).min(h - 1e-9);
        let mut c = 0;
        while c < cols {
            let xc = |c: usize| ((c as f64 + 0.5) * cell).min(w - 1e-9);
            if map.is_water(xc(c), yc) {
                c += 1;
                continue;
            }
            let c0 = c;
            while c < cols && !map.is_water(xc(c), yc) {
                c += 1;
            }
            land.push([(c0 as f64 * cell, y0), ((c as f64 * cell).min(w), (y0 + cell).min(h))]);
        }
    }
    land
}

/// Splits a polyline into dash segments of about `dash` metres.
pub fn dashes(points: &[(f64, f64)], dash: f64) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    for pair in points.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        let steps = ((len / dash).ceil() as usize).max(1);
        for k in (0..steps).step_by(2) {
            let t0 = k as f64 / steps as f64;
            let t1 = ((k + 1) as f64 / steps as f64).min(1.0);
            let lerp = |t: f64| (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
            out.push(vec![lerp(t0), lerp(t1)]);
        }
    }
    out
}

/// An axis tick at two decimals at most, without trailing zeros ("50", "2.5").
fn tick_label(v: f64) -> String {
    // Adding 0.0 turns −0 into +0.
    let text = format!("{:.2}", v + 0.0);
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_drop_trailing_zeros() {
        assert_eq!(tick_label(50.0), "50");
        assert_eq!(tick_label(2.5), "2.5");
        assert_eq!(tick_label(0.30000000000000004), "0.3");
        assert_eq!(tick_label(-0.0), "0");
        assert_eq!(tick_label(-12.25), "-12.25");
    }

    struct Island;
    impl WaterMap for Island {
        fn width_m(&self) -> f64 {
            5000.0
        }
        fn height_m(&self) -> f64 {
            10_000.0
        }
        fn is_water(&self, x: f64, y: f64) -> bool {
            (x - 2500.0).powi(2) + (y - 5000.0).powi(2) > 1000.0f64.powi(2)
        }
        fn segment_over_water(&self, _: (f64, f64), _: (f64, f64)) -> bool {
            true
        }
    }

    fn tmp(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("planner-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
    }

    #[test]
    fn per_run_figure_writes_an_svg_with_every_label() {
        let path = tmp("fig4.svg");
        let a = [1.0, 2.0, 3.0];
        let b = [2.0, 1.5, f64::NAN];
        let series = [
            Series {
                label: "pso",
                values: &a,
            },
            Series {
                label: "bbo",
                values: &b,
            },
        ];
        per_run_figure(
            &path,
            "Cost and CPU time",
            &[
                Panel {
                    y_label: "cost",
                    series: &series,
                },
                Panel {
                    y_label: "CPU time (ms)",
                    series: &series,
                },
            ],
        )
        .unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        for needle in ["<svg", "pso", "bbo", "cost", "CPU time (ms)", "Cost and CPU time"] {
            assert!(svg.contains(needle), "missing {needle}");
        }
    }

    #[test]
    fn empty_data_is_an_error_not_a_blank_figure() {
        let series = [Series {
            label: "pso",
            values: &[],
        }];
        let err = per_run_figure(
            &tmp("empty.svg"),
            "t",
            &[Panel {
                y_label: "y",
                series: &series,
            }],
        )
        .unwrap_err();
        assert!(err.to_string().contains("no data"));
    }

    #[test]
    fn map_figure_draws_land_routes_bounds_and_markers() {
        let path = tmp("map.svg");
        let pts = [(100.0, 100.0), (4000.0, 2000.0), (4500.0, 9000.0)];
        let route = [pts[0], pts[1], pts[2]];
        let fig = MapFigure {
            title: "network",
            map: &Island,
            waypoints: &pts,
            start: 0,
            goal: 2,
            bounds: &[BoundMarker {
                nominal: pts[1],
                bound: (300.0, 200.0),
            }],
            routes: &[
                RouteLayer {
                    label: "before",
                    points: &route,
                    dashed: true,
                },
                RouteLayer {
                    label: "after",
                    points: &route,
                    dashed: false,
                },
            ],
            markers: &[pts[1]],
            marker_label: "re-plan",
        };
        map_figure(&path, &fig).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        for needle in [
            "before",
            "after",
            "re-plan",
            "dynamic bound",
            "start",
            "goal",
            "#DECEA0",
        ] {
            assert!(svg.contains(needle), "missing {needle}");
        }
    }
}
