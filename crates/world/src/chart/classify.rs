//! From chart colours to navigable water: the per-pixel features k-means
//! clusters on, and the rule that says which clusters are water.
//!
//! # Features (why not raw RGB)
//! The chart's classes differ in *hue* (blue water, buff/olive land) and in
//! *darkness* (the near-black coastline ink against light paint), while
//! inside a class the colour moves along a lightness/saturation ramp: water
//! darkens away from the shore, land shades from buff to olive. Raw RGB
//! distance weighs that ramp as much as a change of class, so k = 3 on RGB
//! (or CIELAB) spends its clusters splitting the water or the land in two and
//! merges the one-pixel ink stroke into the deep-water cluster, which the rule
//! then calls water. Measured on both shipped charts: the ink got its own
//! cluster in only a few of ten seeds, and merging it is the lower-inertia
//! solution on Bay of Islands. So each pixel becomes three features:
//! 1. and 2. its hue direction: the opponent-colour chroma vector
//!    (o1 = (R−G)/√2, o2 = (R+G−2B)/√6) scaled to length [`HUE_SCALE`], or
//!    proportionally less when its chroma is under [`CHROMA_FLOOR`], so a
//!    class's saturation ramp collapses to a point and near-greys (ink,
//!    paper) sit near the origin;
//! 3. its squared darkness [`DARKNESS_SCALE`]·(1 − max(R,G,B)/255)²: near 0
//!    for any paint, large for ink; squaring flattens the paints' shading.
//!
//! In this space the three classes are compact and far apart: on both charts,
//! for each of 100 seeds and k ∈ {2, 3, 4, 5, 8}, the result equalled the
//! truth mask on every pixel except the ink stroke, which came out forbidden
//! (`chart::tests::seed_sweep`). No clean-up step is needed.
//!
//! # The water rule
//! A cluster is navigable water when the mean colour of its pixels (in RGB)
//! is **blue** (mean B − mean R ≥ [`WATER_MIN_BLUE_EXCESS`]) **and light**
//! (its brightest channel ≥ [`WATER_MIN_VALUE`]); every other cluster is
//! forbidden. Measured cluster means: water (161, 204, 236), land
//! (217, 201, 154), ink (60, 60, 70). Land fails the first test; the ink
//! fails both (B − R = 10, value 70), so it is forbidden on two counts. The
//! rule holds for any k ≥ 3 (water or land split into shades stay water or
//! land). With k = 2 the ink has no cluster of its own and takes the class
//! of the one it joins: on the shipped charts that happened to be land (it
//! is about equally far from both), which nothing guarantees elsewhere.
//!
//! Contract: [`segment`] is deterministic per [`ClassifySettings`]; it fits on
//! a seeded subsample of [`FIT_SAMPLE_PIXELS`] pixels, then labels every
//! pixel by its nearest centroid.

use super::image::RgbImage;
use super::kmeans::{self, KMeansConfig};
use super::mask::WaterMask;
use super::{
    CHROMA_FLOOR, ChartError, ClassifySettings, DARKNESS_SCALE, FIT_SAMPLE_PIXELS, HUE_SCALE, KMEANS_MAX_ITERATIONS,
    KMEANS_RESTARTS, MAX_K, WATER_MIN_BLUE_EXCESS, WATER_MIN_VALUE,
};
use auv_core::rng::PlannerRng;

/// The feature vector k-means sees for one pixel (see the module docs).
#[inline]
pub fn features([r, g, b]: [u8; 3]) -> [f32; 3] {
    let (r, g, b) = (f32::from(r), f32::from(g), f32::from(b));
    let o1 = (r - g) * core::f32::consts::FRAC_1_SQRT_2;
    let o2 = (r + g - 2.0 * b) * (1.0 / 6f32.sqrt());
    let chroma = (o1 * o1 + o2 * o2).sqrt();
    let scale = HUE_SCALE / chroma.max(CHROMA_FLOOR);
    let darkness = 1.0 - r.max(g).max(b) / 255.0;
    [o1 * scale, o2 * scale, DARKNESS_SCALE * darkness * darkness]
}

/// The water rule on a cluster's mean colour (R, G, B in 0..=255).
pub fn is_water_colour([r, g, b]: [f64; 3]) -> bool {
    b - r >= WATER_MIN_BLUE_EXCESS && r.max(g).max(b) >= WATER_MIN_VALUE
}

/// One cluster of a [`Segmentation`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cluster {
    /// Mean colour of its pixels, R, G, B in 0..=255.
    pub mean_rgb: [f64; 3],
    /// Number of pixels labelled with it.
    pub pixels: usize,
    /// Whether the water rule calls it navigable.
    pub water: bool,
}

/// The result of classifying a chart: the water mask and the clusters it
/// came from (for reports and plots).
#[derive(Clone, Debug, PartialEq)]
pub struct Segmentation {
    /// Navigable water.
    pub mask: WaterMask,
    /// The clusters, in k-means order; at most k (fewer when the chart has
    /// fewer distinct colours).
    pub clusters: Vec<Cluster>,
}

/// Clusters `image` and applies the water rule. `metres_per_pixel` is the
/// mask's scale (already validated by the caller); `what` names the chart in
/// errors.
pub fn segment(
    image: &RgbImage,
    metres_per_pixel: f64,
    settings: &ClassifySettings,
    what: &str,
) -> Result<Segmentation, ChartError> {
    if settings.k == 0 || settings.k > MAX_K {
        return Err(ChartError::BadK { k: settings.k });
    }
    let pixels = image.pixels();
    let mut rng = PlannerRng::new(settings.seed);
    // Fit on a seeded subsample (with replacement): 64 Ki pixels hold about
    // 230 of a 0.35 % ink class, plenty to place its centroid, and keep the
    // fit's cost fixed whatever the chart size.
    let sample: Vec<[f32; 3]> = if pixels.len() <= FIT_SAMPLE_PIXELS {
        pixels.iter().map(|&p| features(p)).collect()
    } else {
        let n = u32::try_from(pixels.len()).unwrap_or(u32::MAX);
        (0..FIT_SAMPLE_PIXELS)
            .map(|_| features(pixels[rng.below(n) as usize]))
            .collect()
    };
    let config = KMeansConfig {
        k: settings.k,
        restarts: KMEANS_RESTARTS,
        max_iterations: KMEANS_MAX_ITERATIONS,
    };
    // The sample is non-empty and finite (features of u8 colours), k ≥ 1:
    // fit cannot fail, but pass any error on rather than unwrap.
    let model = kmeans::fit(&sample, &config, &mut rng).map_err(|e| ChartError::Cluster {
        what: what.to_owned(),
        reason: e.to_string(),
    })?;
    let k = model.centroids().len();
    let mut sums = vec![[0u64; 3]; k];
    let mut counts = vec![0usize; k];
    let mut labels = Vec::with_capacity(pixels.len());
    // Neighbouring pixels often repeat a colour (flat paint, the ink): reuse
    // the last answer instead of recomputing features and distances.
    let mut last: Option<([u8; 3], usize)> = None;
    for &p in pixels {
        let l = match last {
            Some((c, l)) if c == p => l,
            _ => {
                let l = model.nearest(&features(p));
                last = Some((p, l));
                l
            }
        };
        labels.push(l as u8);
        counts[l] += 1;
        for (s, v) in sums[l].iter_mut().zip(p) {
            *s += u64::from(v);
        }
    }
    let clusters: Vec<Cluster> = sums
        .iter()
        .zip(&counts)
        .map(|(s, &n)| {
            let mean_rgb = if n == 0 {
                [0.0; 3]
            } else {
                s.map(|v| v as f64 / n as f64)
            };
            Cluster {
                mean_rgb,
                pixels: n,
                water: n > 0 && is_water_colour(mean_rgb),
            }
        })
        .collect();
    let water = labels.iter().map(|&l| clusters[l as usize].water).collect();
    let mask = WaterMask::new(image.width(), image.height(), metres_per_pixel, water)?;
    if mask.water_cells() == 0 {
        return Err(ChartError::NoWater { what: what.to_owned() });
    }
    Ok(Segmentation { mask, clusters })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chart::WaterMap;

    /// Cluster means measured on the shipped charts (k = 3, default seed).
    const WATER: [f64; 3] = [161.2, 204.3, 236.4];
    const LAND: [f64; 3] = [216.5, 201.3, 153.6];
    const INK: [f64; 3] = [60.0, 60.0, 70.0];

    #[test]
    fn rule_on_measured_cluster_colours() {
        assert!(is_water_colour(WATER));
        assert!(!is_water_colour(LAND));
        assert!(!is_water_colour(INK), "coastline ink is forbidden");
        // Shades the water splits into at larger k stay water: the shore
        // tint and the deepest blue of the charts.
        assert!(is_water_colour([214.0, 246.0, 255.0]));
        assert!(is_water_colour([100.0, 154.0, 205.0]));
        // Olive land, white paper and black are not.
        assert!(!is_water_colour([200.0, 195.0, 140.0]));
        assert!(!is_water_colour([255.0, 255.0, 255.0]));
        assert!(!is_water_colour([0.0, 0.0, 0.0]));
        // A dark navy ink is blue enough but too dark.
        assert!(!is_water_colour([20.0, 30.0, 110.0]));
    }

    #[test]
    fn features_collapse_shades_and_separate_classes() {
        let d = |a: [f32; 3], b: [f32; 3]| a.iter().zip(&b).map(|(x, y)| (x - y) * (x - y)).sum::<f32>().sqrt();
        let shore = features([214, 246, 255]);
        let deep = features([100, 154, 205]);
        let buff = features([225, 205, 159]);
        let olive = features([200, 195, 140]);
        let ink = features([60, 60, 70]);
        let within = d(shore, deep).max(d(buff, olive));
        let between = d(shore, buff).min(d(deep, ink)).min(d(shore, ink)).min(d(buff, ink));
        assert!(between > 3.0 * within, "within {within}, between {between}");
    }

    /// A synthetic chart like the real ones: buff land on the west, a strip
    /// of water darkening eastwards, a one-pixel ink line on the water side
    /// of the coast, and noise.
    fn synthetic(width: usize, height: usize, coast: usize, seed: u64) -> (RgbImage, Vec<bool>) {
        let mut rng = PlannerRng::new(seed);
        let mut px = Vec::with_capacity(width * height);
        let mut truth = Vec::with_capacity(width * height);
        for _row in 0..height {
            for col in 0..width {
                let base: [f64; 3] = if col < coast {
                    [220.0, 203.0, 156.0]
                } else if col == coast {
                    [60.0, 60.0, 70.0]
                } else {
                    let t = (col - coast) as f64 / (width - coast) as f64;
                    [214.0 - 114.0 * t, 246.0 - 92.0 * t, 255.0 - 50.0 * t]
                };
                let noisy = |v: f64, rng: &mut PlannerRng| (v + rng.normal(0.0, 4.0)).round().clamp(0.0, 255.0) as u8;
                px.push(if col == coast {
                    [60, 60, 70]
                } else {
                    [
                        noisy(base[0], &mut rng),
                        noisy(base[1], &mut rng),
                        noisy(base[2], &mut rng),
                    ]
                });
                truth.push(col > coast);
            }
        }
        (RgbImage::new(width, height, px).unwrap(), truth)
    }

    #[test]
    fn synthetic_chart_water_is_found_and_ink_is_forbidden() {
        let (img, truth) = synthetic(120, 80, 50, 5);
        for k in [3, 4, 6] {
            for seed in 0..3 {
                let seg = segment(&img, 10.0, &ClassifySettings { k, seed }, "synthetic").unwrap();
                assert_eq!(
                    seg.mask.cells(),
                    truth.as_slice(),
                    "k {k} seed {seed}: {:?}",
                    seg.clusters
                );
                assert!(!seg.mask.is_water(505.0, 400.0), "ink column");
                assert!(
                    seg.clusters.iter().any(|c| !c.water && c.mean_rgb[0] < 100.0),
                    "an ink cluster"
                );
            }
        }
    }

    #[test]
    fn deterministic_per_seed() {
        let (img, _) = synthetic(300, 300, 120, 9); // 90 000 px: subsampled
        let s = ClassifySettings { k: 3, seed: 4 };
        assert_eq!(
            segment(&img, 10.0, &s, "c").unwrap(),
            segment(&img, 10.0, &s, "c").unwrap()
        );
    }

    #[test]
    fn k_out_of_range_is_an_error() {
        let (img, _) = synthetic(20, 10, 5, 1);
        for k in [0, MAX_K + 1] {
            let err = segment(&img, 10.0, &ClassifySettings { k, seed: 0 }, "c").unwrap_err();
            assert_eq!(err, ChartError::BadK { k });
        }
    }

    #[test]
    fn chart_without_water_is_an_error() {
        let img = RgbImage::new(30, 20, vec![[220, 203, 156]; 600]).unwrap();
        let err = segment(&img, 10.0, &ClassifySettings::default(), "chart `desert.png`").unwrap_err();
        assert!(matches!(err, ChartError::NoWater { .. }), "{err}");
        assert!(err.to_string().contains("desert.png"));
    }
}
