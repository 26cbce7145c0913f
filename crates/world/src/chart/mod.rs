//! Charts: a coastline image clustered into navigable water and forbidden
//! zones, and the geometric queries the world model asks of it.
//!
//! Frame: x east, y north, metres, origin at the chart's south-west corner.
//! Pixel (col, row) covers x ∈ [col·m, (col+1)·m), y ∈ [(H−1−row)·m, (H−row)·m)
//! (row 0 is the northern edge), as `shared/maps/README.md` defines.
//!
//! Pipeline: [`Chart`] (a decoded PNG, [`image`], plus its metres per pixel)
//! → [`Chart::classify`]: k-means on per-pixel colour features ([`kmeans`],
//! [`classify`]) and a documented rule naming the water clusters → a
//! [`WaterMask`] ([`mask`]), which implements [`WaterMap`] for the scenario
//! generator. The chart's RGB raster stays available ([`Chart::image`]) for
//! plots.
//!
//! Every default and tunable is a `const` below with its source: the project's
//! chart set-up (k = 3), `shared/maps/README.md` (the charts' scales, copied with the
//! attribution to `crates/world/assets/ATTRIBUTION.md`), or "our choice" with the
//! measurement behind it.
//!
//! Contract: loading and classifying never panic on bad input; every failure
//! is a [`ChartError`] whose message is one line naming the chart. Results are
//! deterministic per [`ClassifySettings`] (k, seed).

/// What the world model needs from a chart: its extent and where water is.
/// The seam between the chart (image processing) and the scenario generator.
pub trait WaterMap {
    /// East-west extent, m.
    fn width_m(&self) -> f64;
    /// North-south extent, m.
    fn height_m(&self) -> f64;
    /// Whether the point (x east, y north) lies over navigable water. Points
    /// outside the chart are not water.
    fn is_water(&self, x: f64, y: f64) -> bool;
    /// Whether the straight segment from `a` to `b` (x, y in m) stays over
    /// water: every raster cell the segment crosses is water, not only its ends.
    fn segment_over_water(&self, a: (f64, f64), b: (f64, f64)) -> bool;
}

pub mod classify;
pub mod image;
pub mod kmeans;
pub mod land;
pub mod mask;

use std::path::{Path, PathBuf};

use thiserror::Error;

pub use classify::{Cluster, Segmentation};
pub use image::{ImageError, RgbImage};
pub use mask::WaterMask;

// ---------------------------------------------------------------------------
// Defaults and tunables, with their sources (the one place they are set).
// ---------------------------------------------------------------------------

/// Number of k-means clusters. Source: the project's chart set-up (k configurable, default 3):
/// water, land, coastline ink.
pub const DEFAULT_K: usize = 3;
/// Seed of the classification's random choices (subsample, seeding). Our
/// choice; each of 100 seeds gave the same water on both shipped charts
/// (`chart::tests::seed_sweep`).
pub const DEFAULT_CLASSIFY_SEED: u64 = 0;
/// Largest accepted k. Our choice: far more classes than a chart prints, and
/// labels fit a byte.
pub const MAX_K: usize = 16;
/// Pixels the k-means fit sees (drawn with replacement, seeded); every pixel
/// is then labelled. Our choice: keeps the fit a few ms on any chart while a
/// 0.35 % class still gets a few hundred samples.
pub const FIT_SAMPLE_PIXELS: usize = 1 << 16;
/// Greedy k-means++ restarts (best inertia wins). Our choice: one already
/// separated the classes for every seed tried; four is a cheap margin for
/// other charts.
pub const KMEANS_RESTARTS: u32 = 4;
/// Cap on Lloyd iterations per restart. Our choice (on both charts the
/// labels stop changing after the first update).
pub const KMEANS_MAX_ITERATIONS: u32 = 100;
/// Length of the hue-direction feature ([`classify`]). Our choice: a blue ↔
/// buff hue reversal (2 × 50) weighs about as much as paint ↔ ink darkness.
pub const HUE_SCALE: f32 = 50.0;
/// Chroma (opponent-colour units, 0..≈180) below which the hue feature
/// shrinks towards 0. Our choice: the palest shore water has chroma ≈ 30, the
/// ink ≈ 8.
pub const CHROMA_FLOOR: f32 = 24.0;
/// Weight of the squared-darkness feature. Our choice: ink (value 70) lands
/// at ≈ 270, every paint of the charts within 0–45. At half this weight a
/// single k-means++ seeding merged the ink into the water in 15–23 % of seeds;
/// at this weight in none of 200 (both charts).
pub const DARKNESS_SCALE: f32 = 512.0;
/// Water rule: least mean B − mean R of a water cluster (0..=255 units). Our
/// choice between ink (+10) and the palest water (+41); land is ≈ −60.
pub const WATER_MIN_BLUE_EXCESS: f64 = 20.0;
/// Water rule: least brightest-channel mean of a water cluster. Our choice
/// between ink (70) and the deepest water (≈ 205).
pub const WATER_MIN_VALUE: f64 = 128.0;
/// Largest chart accepted, pixels (about 4096 × 4096). Our choice: bounds
/// memory (≈ 70 MB while classifying) whatever file is given.
pub const MAX_CHART_PIXELS: usize = 1 << 24;
/// Largest accepted pixel size, m. Our choice: a pixel over 1000 km wide is a
/// typo, not a chart.
pub const MAX_METRES_PER_PIXEL: f64 = 1.0e6;

/// A chart the product ships, with its scale (source: `shared/maps/README.md`,
/// copied to `crates/world/assets/ATTRIBUTION.md`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KnownChart {
    /// File name.
    pub file_name: &'static str,
    /// Pixel size, m.
    pub metres_per_pixel: f64,
}

/// Benoit's Cove: 500 × 1000 px, 10 m/px (5 km × 10 km). The default chart.
pub const BENOITS_COVE: KnownChart = KnownChart {
    file_name: "benoits-cove.png",
    metres_per_pixel: 10.0,
};
/// Bay of Islands: 1250 × 1250 px, 20 m/px (25 km × 25 km).
pub const BAY_OF_ISLANDS: KnownChart = KnownChart {
    file_name: "bay-of-islands.png",
    metres_per_pixel: 20.0,
};
/// The charts whose scale is known from their file name.
pub const KNOWN_CHARTS: [KnownChart; 2] = [BENOITS_COVE, BAY_OF_ISLANDS];

/// The default chart's PNG, embedded so the binary runs with no files.
pub const EMBEDDED_CHART_PNG: &[u8] = include_bytes!("../../assets/benoits-cove.png");

// ---------------------------------------------------------------------------

/// Why a chart could not be loaded or classified. Each message is one line
/// naming the chart.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ChartError {
    /// A scenario named an embedded chart the binary does not carry.
    #[error("unknown embedded chart `{name}`: the embedded chart is `benoits-cove`; give other charts as a PNG file")]
    UnknownEmbedded {
        /// The name asked for.
        name: String,
    },
    /// The file could not be read.
    #[error("cannot read chart file `{path}`: {reason}")]
    Io {
        /// The path given.
        path: String,
        /// The OS error.
        reason: String,
    },
    /// The bytes are not a usable PNG.
    #[error("{what}: {source}")]
    Image {
        /// Which chart or mask.
        what: String,
        /// What is wrong with it.
        source: ImageError,
    },
    /// Metres per pixel not finite, not positive, or absurdly large.
    #[error("metres per pixel must be a finite number > 0 and ≤ {MAX_METRES_PER_PIXEL}, got {value}")]
    BadScale {
        /// The value given.
        value: f64,
    },
    /// A chart file whose scale is not known from its name and was not given.
    #[error(
        "metres per pixel of chart `{path}` is unknown: give it explicitly \
         (known from the file name: benoits-cove.png 10 m/px, bay-of-islands.png 20 m/px)"
    )]
    UnknownScale {
        /// The path given.
        path: String,
    },
    /// k outside 1..=[`MAX_K`].
    #[error("k (number of colour clusters) must be between 1 and {MAX_K}, got {k}")]
    BadK {
        /// The value given.
        k: usize,
    },
    /// Clustering failed (not expected on a decoded image).
    #[error("{what}: colour clustering failed: {reason}")]
    Cluster {
        /// Which chart.
        what: String,
        /// Why.
        reason: String,
    },
    /// No pixel was classified as water.
    #[error("{what}: no navigable water found (no colour cluster is a light blue)")]
    NoWater {
        /// Which chart or mask.
        what: String,
    },
    /// A mask's flag count does not match its size.
    #[error("water mask of {width} x {height} pixels cannot hold {cells} cells")]
    MaskSize {
        /// Width, px.
        width: usize,
        /// Height, px.
        height: usize,
        /// Flags given.
        cells: usize,
    },
    /// Two masks of different sizes compared.
    #[error("cannot compare a {}x{} mask with a {}x{} mask", left.0, left.1, right.0, right.1)]
    SizeMismatch {
        /// (width, height) px of the first.
        left: (usize, usize),
        /// (width, height) px of the second.
        right: (usize, usize),
    },
}

/// Checks a pixel size, m.
pub(crate) fn validate_scale(metres_per_pixel: f64) -> Result<(), ChartError> {
    if metres_per_pixel.is_finite() && metres_per_pixel > 0.0 && metres_per_pixel <= MAX_METRES_PER_PIXEL {
        Ok(())
    } else {
        Err(ChartError::BadScale {
            value: metres_per_pixel,
        })
    }
}

/// How to turn a chart into water (k and seed; see [`classify`] for the
/// features and the water rule).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ClassifySettings {
    /// Number of colour clusters, 1..=[`MAX_K`]; ≥ 3 separates the coastline
    /// ink. Default [`DEFAULT_K`].
    pub k: usize,
    /// Seed of the subsample and the k-means seeding. Default
    /// [`DEFAULT_CLASSIFY_SEED`].
    pub seed: u64,
}

impl Default for ClassifySettings {
    fn default() -> Self {
        Self {
            k: DEFAULT_K,
            seed: DEFAULT_CLASSIFY_SEED,
        }
    }
}

/// Where a chart comes from: what a scenario file or CLI names.
#[derive(Clone, Debug, PartialEq)]
pub enum ChartSpec {
    /// The embedded Benoit's Cove chart (10 m/px).
    Embedded,
    /// A PNG file; its scale in m/px, or `None` to take it from
    /// [`KNOWN_CHARTS`] by file name.
    File {
        /// Path of the PNG.
        path: PathBuf,
        /// Pixel size, m, if given.
        metres_per_pixel: Option<f64>,
    },
}

/// A chart image and its scale: the input of classification, and the
/// backdrop plots draw.
#[derive(Clone, Debug, PartialEq)]
pub struct Chart {
    name: String,
    image: RgbImage,
    metres_per_pixel: f64,
}

impl Chart {
    /// The embedded default chart, Benoit's Cove at 10 m/px.
    pub fn embedded_default() -> Result<Self, ChartError> {
        Self::from_png_bytes(EMBEDDED_CHART_PNG, BENOITS_COVE.metres_per_pixel)
            .map(|c| c.named("embedded chart benoits-cove.png"))
    }

    /// Any PNG held in memory, with its pixel size in m.
    pub fn from_png_bytes(bytes: &[u8], metres_per_pixel: f64) -> Result<Self, ChartError> {
        Self::decode(bytes, metres_per_pixel, "chart".to_owned())
    }

    /// A PNG file; `metres_per_pixel` `None` looks the scale up in
    /// [`KNOWN_CHARTS`] by file name (so `bay-of-islands.png` loads at 20 m/px).
    pub fn from_png_file(path: &Path, metres_per_pixel: Option<f64>) -> Result<Self, ChartError> {
        let shown = path.display().to_string();
        let scale = match metres_per_pixel {
            Some(m) => m,
            None => known_scale(path).ok_or_else(|| ChartError::UnknownScale { path: shown.clone() })?,
        };
        validate_scale(scale)?;
        let bytes = std::fs::read(path).map_err(|e| ChartError::Io {
            path: shown.clone(),
            reason: e.to_string(),
        })?;
        Self::decode(&bytes, scale, format!("chart `{shown}`"))
    }

    /// Loads what `spec` names.
    pub fn load(spec: &ChartSpec) -> Result<Self, ChartError> {
        match spec {
            ChartSpec::Embedded => Self::embedded_default(),
            ChartSpec::File { path, metres_per_pixel } => Self::from_png_file(path, *metres_per_pixel),
        }
    }

    fn decode(bytes: &[u8], metres_per_pixel: f64, name: String) -> Result<Self, ChartError> {
        validate_scale(metres_per_pixel)?;
        let image = image::decode_png(bytes).map_err(|source| ChartError::Image {
            what: name.clone(),
            source,
        })?;
        Ok(Self {
            name,
            image,
            metres_per_pixel,
        })
    }

    /// The same chart under another name (used in error messages).
    pub fn named(mut self, name: impl Into<String>) -> Self {
        self.name = name.into();
        self
    }

    /// How errors name this chart.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The RGB raster, row 0 north.
    pub fn image(&self) -> &RgbImage {
        &self.image
    }

    /// Pixel size, m.
    pub fn metres_per_pixel(&self) -> f64 {
        self.metres_per_pixel
    }

    /// East-west extent, m.
    pub fn width_m(&self) -> f64 {
        self.image.width() as f64 * self.metres_per_pixel
    }

    /// North-south extent, m.
    pub fn height_m(&self) -> f64 {
        self.image.height() as f64 * self.metres_per_pixel
    }

    /// The navigable water (k-means on colour, then the water rule).
    pub fn classify(&self, settings: &ClassifySettings) -> Result<WaterMask, ChartError> {
        self.segment(settings).map(|s| s.mask)
    }

    /// The water mask together with the clusters it came from.
    pub fn segment(&self, settings: &ClassifySettings) -> Result<Segmentation, ChartError> {
        classify::segment(&self.image, self.metres_per_pixel, settings, &self.name)
    }
}

/// Scale of a shipped chart recognised by file name.
fn known_scale(path: &Path) -> Option<f64> {
    let name = path.file_name()?.to_str()?;
    KNOWN_CHARTS
        .iter()
        .find(|k| k.file_name == name)
        .map(|k| k.metres_per_pixel)
}

#[cfg(test)]
mod tests;
