//! Tests of the chart layer on the shipped charts (`crates/world/assets/`) and of
//! the `Chart` API's bad-input handling.

use super::*;

fn asset(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets").join(name)
}

fn truth(name: &str, metres_per_pixel: f64) -> WaterMask {
    let bytes = std::fs::read(asset(name)).unwrap();
    WaterMask::from_mask_png(&bytes, metres_per_pixel, name).unwrap()
}

/// Pixels drawn in dark ink (the coastline stroke): brightest channel < 128.
fn ink_cells(chart: &Chart) -> Vec<usize> {
    let px = chart.image().pixels();
    (0..px.len()).filter(|&i| px[i].iter().all(|&v| v < 128)).collect()
}

/// IoU with the truth ≥ 0.98, and every ink pixel forbidden.
fn check(chart: &Chart, truth: &WaterMask, settings: &ClassifySettings) -> f64 {
    let mask = chart.classify(settings).unwrap();
    let iou = mask.iou(truth).unwrap();
    assert!(iou >= 0.98, "{}: IoU {iou:.4} with {settings:?}", chart.name());
    let ink = ink_cells(chart);
    // The stroke is there (about 0.35 % of the pixels)...
    assert!(ink.len() * 1000 > mask.cells().len(), "{} ink pixels", ink.len());
    // ...all on the truth's water side, and none of it comes out water.
    assert!(ink.iter().all(|&i| truth.cells()[i]));
    let wet_ink = ink.iter().filter(|&&i| mask.cells()[i]).count();
    assert_eq!(wet_ink, 0, "{}: ink classified as water", chart.name());
    iou
}

#[test]
fn embedded_chart_is_benoits_cove_at_10_m() {
    let chart = Chart::embedded_default().unwrap();
    assert_eq!((chart.image().width(), chart.image().height()), (500, 1000));
    assert_eq!(chart.metres_per_pixel(), 10.0);
    assert_eq!((chart.width_m(), chart.height_m()), (5000.0, 10000.0));
    assert_eq!(
        EMBEDDED_CHART_PNG,
        std::fs::read(asset("benoits-cove.png")).unwrap().as_slice()
    );
}

#[test]
fn benoits_cove_water_matches_truth() {
    let chart = Chart::embedded_default().unwrap();
    let truth = truth("benoits-cove-mask.png", 10.0);
    let iou = check(&chart, &truth, &ClassifySettings::default());
    eprintln!("benoits-cove IoU {iou:.4}");
    // Other seeds and a larger k find the same water.
    for settings in [
        ClassifySettings { k: 3, seed: 1 },
        ClassifySettings { k: 3, seed: 2 },
        ClassifySettings { k: 5, seed: 0 },
    ] {
        check(&chart, &truth, &settings);
    }
}

#[test]
fn bay_of_islands_loads_by_name_and_matches_truth() {
    let chart = Chart::from_png_file(&asset("bay-of-islands.png"), None).unwrap();
    assert_eq!(chart.metres_per_pixel(), 20.0);
    assert_eq!((chart.width_m(), chart.height_m()), (25_000.0, 25_000.0));
    let truth = truth("bay-of-islands-mask.png", 20.0);
    let iou = check(&chart, &truth, &ClassifySettings::default());
    eprintln!("bay-of-islands IoU {iou:.4}");
    check(&chart, &truth, &ClassifySettings { k: 4, seed: 7 });
}

#[test]
fn classified_chart_answers_geometric_queries() {
    let mask = Chart::embedded_default()
        .unwrap()
        .classify(&ClassifySettings::default())
        .unwrap();
    // Mid-channel water (the arm runs NW-SE) and the south-west land.
    assert!(mask.is_water(2500.0, 5000.0));
    assert!(!mask.is_water(500.0, 1000.0));
    // Down the channel stays wet; straight across the western land does not.
    assert!(mask.segment_over_water((2500.0, 5000.0), (2700.0, 6500.0)));
    assert!(!mask.segment_over_water((2500.0, 5000.0), (300.0, 3000.0)));
    let f = mask.water_fraction();
    assert!((0.40..0.45).contains(&f), "water fraction {f}");
}

#[test]
fn bad_inputs_are_clear_errors() {
    let err = Chart::from_png_bytes(b"GIF89a not a png", 10.0).unwrap_err();
    assert!(
        matches!(
            err,
            ChartError::Image {
                source: ImageError::NotPng,
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("not a PNG"));

    for bad in [0.0, -10.0, f64::NAN, f64::INFINITY, 2.0e6] {
        let err = Chart::from_png_bytes(EMBEDDED_CHART_PNG, bad).unwrap_err();
        assert!(matches!(err, ChartError::BadScale { .. }), "{bad}: {err}");
        assert!(err.to_string().contains("metres per pixel"));
    }

    let err = Chart::from_png_file(Path::new("/nonexistent/chart.png"), Some(10.0)).unwrap_err();
    assert!(matches!(err, ChartError::Io { .. }), "{err}");
    assert!(err.to_string().contains("/nonexistent/chart.png"));

    let err = Chart::from_png_file(Path::new("/some/where/harbour.png"), None).unwrap_err();
    assert!(matches!(err, ChartError::UnknownScale { .. }), "{err}");

    let err = Chart::embedded_default()
        .unwrap()
        .classify(&ClassifySettings { k: 0, seed: 0 })
        .unwrap_err();
    assert_eq!(err, ChartError::BadK { k: 0 });

    // A chart of land only (a 1-pixel-wide strip of buff).
    let dry = image::tests::encode(
        3,
        2,
        ::png::ColorType::Rgb,
        ::png::BitDepth::Eight,
        None,
        None,
        &[220, 203, 156].repeat(6),
    );
    let err = Chart::from_png_bytes(&dry, 10.0)
        .unwrap()
        .named("chart `dry.png`")
        .classify(&ClassifySettings::default())
        .unwrap_err();
    assert!(matches!(err, ChartError::NoWater { .. }));
    assert_eq!(
        err.to_string(),
        "chart `dry.png`: no navigable water found (no colour cluster is a light blue)"
    );
}

#[test]
fn spec_loads_embedded_and_files() {
    assert_eq!(
        Chart::load(&ChartSpec::Embedded).unwrap(),
        Chart::embedded_default().unwrap()
    );
    let spec = ChartSpec::File {
        path: asset("benoits-cove.png"),
        metres_per_pixel: Some(2.5),
    };
    let chart = Chart::load(&spec).unwrap();
    assert_eq!(chart.metres_per_pixel(), 2.5);
    assert!(chart.name().contains("benoits-cove.png"));
}

/// Longer check, not run by default: 100 seeds × k ∈ {2, 3, 4, 5, 8} on
/// both charts. `cargo test --release -p planner --lib chart::tests::seed_sweep -- --ignored --nocapture`
#[test]
#[ignore = "slow: 1000 classifications"]
fn seed_sweep() {
    for (file, mask, mpp) in [
        ("benoits-cove.png", "benoits-cove-mask.png", 10.0),
        ("bay-of-islands.png", "bay-of-islands-mask.png", 20.0),
    ] {
        let chart = Chart::from_png_file(&asset(file), Some(mpp)).unwrap();
        let truth = truth(mask, mpp);
        let ink = ink_cells(&chart);
        for k in [2usize, 3, 4, 5, 8] {
            let (mut lo, mut hi, mut wet_runs) = (1.0f64, 0.0f64, 0);
            for seed in 0..100 {
                let m = chart.classify(&ClassifySettings { k, seed }).unwrap();
                let iou = m.iou(&truth).unwrap();
                lo = lo.min(iou);
                hi = hi.max(iou);
                wet_runs += usize::from(ink.iter().any(|&i| m.cells()[i]));
            }
            eprintln!("{file} k {k}: IoU min {lo:.5} max {hi:.5}, runs with wet ink {wet_runs}/100");
            assert!(lo >= 0.98 && wet_runs == 0);
        }
    }
}

/// Prints the median classification time of each chart (no assertion: the
/// machine is shared). `cargo test --release -p planner --lib chart::tests::classification_timing -- --ignored --nocapture`
#[test]
#[ignore = "measurement, not a test"]
fn classification_timing() {
    for (file, mpp) in [("benoits-cove.png", 10.0), ("bay-of-islands.png", 20.0)] {
        let bytes = std::fs::read(asset(file)).unwrap();
        let mut decode = Vec::new();
        let mut classify = Vec::new();
        for _ in 0..7 {
            let t = std::time::Instant::now();
            let chart = Chart::from_png_bytes(&bytes, mpp).unwrap();
            decode.push(t.elapsed().as_secs_f64() * 1e3);
            let t = std::time::Instant::now();
            let mask = chart.classify(&ClassifySettings::default()).unwrap();
            classify.push(t.elapsed().as_secs_f64() * 1e3);
            assert!(mask.water_cells() > 0);
        }
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        eprintln!(
            "{file}: decode median {:.1} ms, classify median {:.1} ms (7 runs)",
            median(&mut decode),
            median(&mut classify)
        );
    }
}
