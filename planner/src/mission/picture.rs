//! The mission picture (`mission.svg` and `mission.png`): what happened, at
//! a glance.
//!
//! Contract: the map keeps the chart's aspect ratio and shows land and
//! water, each dynamic waypoint's bound (ellipse) and the positions the
//! sensor reported for it over the mission (small dots), every waypoint
//! labelled with its name from the mission file (generated ones by id), the
//! first plan (dashed), the route travelled coloured by mission time
//! (viridis, 0 → the budget, with the arrival time in minutes at every
//! visited waypoint), and a marker only where a re-plan changed the route.
//! The legend, the time scale and the summary (outcome, time used of the
//! budget, tasks, weight, plans, p99 latency, deadline misses) sit in a panel
//! right of the map, never on it. The same drawing goes to an SVG and to a
//! PNG (bitmap backend; DejaVu Sans embedded, so no system font is needed).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::colors::colormaps::ViridisRGB;

use crate::plot::PlotError;
use auv_world::chart::WaterMap;

/// One waypoint on the map.
pub struct PicWaypoint {
    /// Nominal position, m.
    pub at: (f64, f64),
    /// Its label.
    pub label: String,
    /// Start, goal, other.
    pub kind: PicKind,
}

/// What a waypoint is, for its marker.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum PicKind {
    /// The start.
    Start,
    /// The goal.
    Goal,
    /// Any other.
    Via,
}

/// A drifting waypoint: its bound and where it was reported.
pub struct PicDrift {
    /// Nominal position, m.
    pub nominal: (f64, f64),
    /// Bound along x and y, m.
    pub bound: (f64, f64),
    /// Reported positions over the mission, m.
    pub reported: Vec<(f64, f64)>,
}

/// Everything the picture shows.
pub struct Picture<'a> {
    /// Title.
    pub title: String,
    /// Land and water.
    pub map: &'a dyn WaterMap,
    /// By node id.
    pub waypoints: Vec<PicWaypoint>,
    /// Dynamic waypoints.
    pub drifts: Vec<PicDrift>,
    /// The first plan through nominal positions.
    pub first_plan: Vec<(f64, f64)>,
    /// Where the vehicle was, with the mission time, s.
    pub travelled: Vec<((f64, f64), f64)>,
    /// Where a re-plan changed the route.
    pub changes: Vec<(f64, f64)>,
    /// The time scale's end (the budget), s.
    pub budget_s: f64,
    /// Summary lines.
    pub summary: Vec<String>,
}

const LAND: RGBColor = RGBColor(222, 206, 160);
const WATER: RGBColor = RGBColor(214, 232, 246);
const FIRST_PLAN: RGBColor = RGBColor(31, 119, 180);
const CHANGE: RGBColor = RGBColor(255, 127, 14);
const START: RGBColor = RGBColor(44, 160, 44);
const GOAL: RGBColor = RGBColor(148, 103, 189);
const GREY: RGBColor = RGBColor(90, 90, 90);
/// Width of the panel right of the map, px.
const PANEL_W: u32 = 330;
/// The map's longer side, px.
const MAP_PX: f64 = 900.0;

/// Writes `stem.svg` and `stem.png`.
pub fn write(stem: &Path, pic: &Picture<'_>) -> Result<(), PlotError> {
    let (w, h) = (pic.map.width_m(), pic.map.height_m());
    if !(w > 0.0 && h > 0.0) {
        return Err(PlotError::Empty(stem.display().to_string()));
    }
    let scale = MAP_PX / w.max(h);
    let size = ((w * scale) as u32 + 90 + PANEL_W, ((h * scale) as u32 + 100).max(620));
    // Both backends measure text with the registered font.
    crate::plot::register_font();
    let svg = stem.with_extension("svg");
    let err = |path: &Path, e: String| PlotError::Draw {
        path: path.display().to_string(),
        message: e,
    };
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        draw(&root, pic).map_err(|e| err(&svg, e))?;
        root.present().map_err(|e| err(&svg, e.to_string()))?;
    }
    let png = stem.with_extension("png");
    // Drawn into memory and encoded with the `png` crate the chart reader
    // already uses (plotters' own encoder would pull in the `image` crate).
    let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        draw(&root, pic).map_err(|e| err(&png, e))?;
        root.present().map_err(|e| err(&png, e.to_string()))?;
    }
    let file = std::fs::File::create(&png).map_err(|e| err(&png, e.to_string()))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), size.0, size.1);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header().map_err(|e| err(&png, e.to_string()))?;
    w.write_image_data(&rgb).map_err(|e| err(&png, e.to_string()))
}

fn time_colour(t: f64, budget: f64) -> RGBColor {
    ViridisRGB::get_color((t / budget.max(1e-9)).clamp(0.0, 1.0))
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, pic: &Picture<'_>) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let (total_w, _) = root.dim_in_pixel();
    let (map_area, panel) = root.split_horizontally(total_w - PANEL_W);
    let (w, h) = (pic.map.width_m(), pic.map.height_m());
    let mut chart = ChartBuilder::on(&map_area)
        .caption(&pic.title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(36)
        .y_label_area_size(56)
        .build_cartesian_2d(0.0..w, 0.0..h)
        .map_err(e)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("x east (m)")
        .y_desc("y north (m)")
        .label_style(("sans-serif", 12))
        .draw()
        .map_err(e)?;
    chart.plotting_area().fill(&WATER).map_err(e)?;
    let cell = w.max(h) / 250.0;
    chart
        .draw_series(
            crate::plot::land_cells(pic.map, 250)
                .into_iter()
                .map(|r| Rectangle::new(r, LAND.filled())),
        )
        .map_err(e)?;

    // Drift: bound ellipses and the reported positions.
    for d in &pic.drifts {
        let pts: Vec<(f64, f64)> = (0..=48)
            .map(|k| {
                let t = std::f64::consts::TAU * k as f64 / 48.0;
                (d.nominal.0 + d.bound.0 * t.cos(), d.nominal.1 + d.bound.1 * t.sin())
            })
            .collect();
        chart
            .draw_series([PathElement::new(pts, GREY.stroke_width(1))])
            .map_err(e)?;
        chart
            .draw_series(d.reported.iter().map(|&p| Circle::new(p, 1, GREY.mix(0.5).filled())))
            .map_err(e)?;
    }
    // The first plan, dashed.
    let dash = w.max(h) / 120.0;
    chart
        .draw_series(
            crate::plot::dashes(&pic.first_plan, dash)
                .into_iter()
                .map(|seg| PathElement::new(seg, FIRST_PLAN.stroke_width(1))),
        )
        .map_err(e)?;
    // The route travelled, each leg in the colour of its arrival time.
    for leg in pic.travelled.windows(2) {
        let c = time_colour(leg[1].1, pic.budget_s);
        chart
            .draw_series([PathElement::new(vec![leg[0].0, leg[1].0], c.stroke_width(3))])
            .map_err(e)?;
    }
    // Waypoints and their names.
    for wp in &pic.waypoints {
        match wp.kind {
            PicKind::Via => chart.draw_series([Circle::new(wp.at, 3, BLACK.filled())]).map_err(e)?,
            PicKind::Start | PicKind::Goal => {
                let c = if wp.kind == PicKind::Start { START } else { GOAL };
                chart
                    .draw_series([Rectangle::new(
                        [(wp.at.0 - cell, wp.at.1 - cell), (wp.at.0 + cell, wp.at.1 + cell)],
                        c.filled(),
                    )])
                    .map_err(e)?
            }
        };
        chart
            .draw_series([Text::new(
                wp.label.clone(),
                (wp.at.0 + 1.5 * cell, wp.at.1 + 1.5 * cell),
                ("sans-serif", 11).into_font().color(&BLACK),
            )])
            .map_err(e)?;
    }
    // Arrival times (minutes) at the visited waypoints.
    for &(p, t) in pic.travelled.iter().skip(1) {
        chart
            .draw_series([Text::new(
                format!("{:.0}′", t / 60.0),
                (p.0 + 1.5 * cell, p.1 - 2.5 * cell),
                ("sans-serif", 10).into_font().color(&time_colour(t, pic.budget_s)),
            )])
            .map_err(e)?;
    }
    chart
        .draw_series(pic.changes.iter().map(|&p| TriangleMarker::new(p, 6, CHANGE.filled())))
        .map_err(e)?;

    draw_panel(&panel, pic).map_err(e)
}

fn draw_panel<DB: DrawingBackend>(
    panel: &DrawingArea<DB, Shift>,
    pic: &Picture<'_>,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let font = |s: u32| ("sans-serif", s).into_font().color(&BLACK);
    let x0 = 10;
    let mut y = 50;
    panel.draw(&Text::new("Legend", (x0, y), font(16)))?;
    y += 26;
    let row = |y: i32, label: &str| Text::new(label.to_string(), (x0 + 34, y - 6), font(13));
    panel.draw(&Rectangle::new([(x0 + 6, y - 6), (x0 + 18, y + 6)], START.filled()))?;
    panel.draw(&row(y, "start"))?;
    y += 22;
    panel.draw(&Rectangle::new([(x0 + 6, y - 6), (x0 + 18, y + 6)], GOAL.filled()))?;
    panel.draw(&row(y, "goal"))?;
    y += 22;
    panel.draw(&Circle::new((x0 + 12, y), 3, BLACK.filled()))?;
    panel.draw(&row(y, "waypoint (name from the mission file)"))?;
    y += 22;
    panel.draw(&Circle::new((x0 + 12, y), 8, GREY.stroke_width(1)))?;
    panel.draw(&Circle::new((x0 + 14, y + 2), 1, GREY.filled()))?;
    panel.draw(&row(y, "drifting waypoint: bound, reported positions"))?;
    y += 22;
    for k in 0..3 {
        panel.draw(&PathElement::new(
            vec![(x0 + 2 + 9 * k, y), (x0 + 7 + 9 * k, y)],
            FIRST_PLAN.stroke_width(1),
        ))?;
    }
    panel.draw(&row(y, "first plan"))?;
    y += 22;
    panel.draw(&PathElement::new(
        vec![(x0, y), (x0 + 26, y)],
        time_colour(0.5, 1.0).stroke_width(3),
    ))?;
    panel.draw(&row(y, "route travelled, by mission time"))?;
    y += 22;
    panel.draw(&TriangleMarker::new((x0 + 12, y), 6, CHANGE.filled()))?;
    panel.draw(&row(y, "re-plan that changed the route"))?;
    y += 30;
    // The time scale.
    panel.draw(&Text::new("mission time (′ = minutes)", (x0, y), font(13)))?;
    y += 18;
    let bar_w = PANEL_W as i32 - 40;
    for k in 0..bar_w {
        let c = time_colour(k as f64, bar_w as f64);
        panel.draw(&Rectangle::new([(x0 + k, y), (x0 + k + 1, y + 14)], c.filled()))?;
    }
    y += 30;
    panel.draw(&Text::new("0", (x0, y - 10), font(11)))?;
    panel.draw(&Text::new(
        format!("{:.0} s (budget)", pic.budget_s),
        (x0 + bar_w - 90, y - 10),
        font(11),
    ))?;
    y += 24;
    panel.draw(&Text::new("Summary", (x0, y), font(16)))?;
    y += 24;
    for line in &pic.summary {
        panel.draw(&Text::new(line.clone(), (x0, y), font(13)))?;
        y += 19;
    }
    Ok(())
}
