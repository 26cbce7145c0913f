//! PNG decoding into an 8-bit RGB raster.
//!
//! Contract: [`decode_png`] accepts any PNG the `png` crate reads (greyscale,
//! RGB, palette, with or without alpha or `tRNS`, 1 to 16 bits per sample,
//! interlaced or not; only the first frame of an animated PNG) and returns an
//! [`RgbImage`] with one `[r, g, b]` per pixel, row 0 first (the northern edge
//! of a chart). Anything else is an [`ImageError`], never a panic:
//! - bit depths are normalised by the crate (`EXPAND` | `STRIP_16`: palette
//!   and low-bit greyscale expanded to 8 bits, 16-bit samples cut to their
//!   high byte);
//! - greyscale becomes r = g = b;
//! - alpha is composited over white paper, so a transparent area reads as
//!   blank paper (never as water) instead of as whatever colour happens to
//!   sit under a zero alpha.

use std::io::Cursor;

use thiserror::Error;

use super::MAX_CHART_PIXELS;

/// Why a PNG could not become an [`RgbImage`].
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum ImageError {
    /// The bytes do not start with the PNG signature.
    #[error("not a PNG file (the PNG signature is missing)")]
    NotPng,
    /// A PNG signature, but the stream is damaged or unsupported.
    #[error("corrupt or unsupported PNG: {0}")]
    Corrupt(String),
    /// Zero width or height.
    #[error("the image is empty ({width} x {height} pixels)")]
    ZeroSize {
        /// Width, px.
        width: u32,
        /// Height, px.
        height: u32,
    },
    /// More pixels than [`MAX_CHART_PIXELS`].
    #[error("the image is too large ({width} x {height} pixels; at most {max} pixels are accepted)")]
    TooLarge {
        /// Width, px.
        width: u32,
        /// Height, px.
        height: u32,
        /// The limit, px.
        max: usize,
    },
}

/// An 8-bit RGB raster, row-major, row 0 at the top (north).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RgbImage {
    width: usize,
    height: usize,
    pixels: Vec<[u8; 3]>,
}

impl RgbImage {
    /// An image from its pixels (row-major, `width * height` of them).
    pub fn new(width: usize, height: usize, pixels: Vec<[u8; 3]>) -> Result<Self, ImageError> {
        let w32 = u32::try_from(width).unwrap_or(u32::MAX);
        let h32 = u32::try_from(height).unwrap_or(u32::MAX);
        if width == 0 || height == 0 {
            return Err(ImageError::ZeroSize {
                width: w32,
                height: h32,
            });
        }
        match width.checked_mul(height) {
            Some(n) if n <= MAX_CHART_PIXELS => {}
            _ => {
                return Err(ImageError::TooLarge {
                    width: w32,
                    height: h32,
                    max: MAX_CHART_PIXELS,
                });
            }
        }
        if pixels.len() != width * height {
            return Err(ImageError::Corrupt(format!(
                "{} pixels given for a {width} x {height} image",
                pixels.len()
            )));
        }
        Ok(Self { width, height, pixels })
    }

    /// Width, px (columns, west to east).
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height, px (rows, north to south).
    pub fn height(&self) -> usize {
        self.height
    }

    /// All pixels, row-major from the north-west corner.
    pub fn pixels(&self) -> &[[u8; 3]] {
        &self.pixels
    }

    /// The pixel at column `col` (from the west) and row `row` (from the
    /// north), or `None` outside the image.
    pub fn get(&self, col: usize, row: usize) -> Option<[u8; 3]> {
        (col < self.width && row < self.height).then(|| self.pixels[row * self.width + col])
    }
}

/// The eight bytes every PNG starts with (PNG spec §5.2).
const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1A, b'\n'];

/// Decodes a PNG held in memory into an [`RgbImage`] (see the module
/// contract for how colour types are mapped).
pub fn decode_png(bytes: &[u8]) -> Result<RgbImage, ImageError> {
    if !bytes.starts_with(&PNG_SIGNATURE) {
        return Err(ImageError::NotPng);
    }
    // The crate's own allocation limit, sized to our pixel limit at the widest
    // output (16-bit RGBA before stripping) plus slack for row buffers.
    let limits = png::Limits {
        bytes: MAX_CHART_PIXELS.saturating_mul(8).saturating_add(1 << 20),
    };
    let mut decoder = png::Decoder::new_with_limits(Cursor::new(bytes), limits);
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let corrupt = |e: png::DecodingError| ImageError::Corrupt(e.to_string());
    // Check the size from the header before the crate allocates anything
    // proportional to it.
    let (width, height) = decoder.read_header_info().map_err(corrupt)?.size();
    if width == 0 || height == 0 {
        return Err(ImageError::ZeroSize { width, height });
    }
    let n_pixels = (width as usize).checked_mul(height as usize);
    if n_pixels.is_none_or(|n| n > MAX_CHART_PIXELS) {
        return Err(ImageError::TooLarge {
            width,
            height,
            max: MAX_CHART_PIXELS,
        });
    }
    let mut reader = decoder.read_info().map_err(corrupt)?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| ImageError::Corrupt("image buffer size overflows".into()))?;
    let mut buf = vec![0u8; size];
    let frame = reader.next_frame(&mut buf).map_err(corrupt)?;
    let (w, h) = (frame.width as usize, frame.height as usize);
    let data = &buf[..frame.buffer_size()];
    let channels = match frame.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => {
            // EXPAND always turns a palette into RGB(A); reaching here would
            // mean the crate changed that contract.
            return Err(ImageError::Corrupt("palette was not expanded".into()));
        }
    };
    if frame.bit_depth != png::BitDepth::Eight {
        return Err(ImageError::Corrupt(format!(
            "unexpected {:?} samples after normalisation",
            frame.bit_depth
        )));
    }
    let line = frame.line_size;
    if line < w * channels || data.len() < line * h {
        return Err(ImageError::Corrupt(
            "decoded frame is shorter than its header says".into(),
        ));
    }
    let mut pixels = Vec::with_capacity(w * h);
    for row in data.chunks_exact(line).take(h) {
        for px in row[..w * channels].chunks_exact(channels) {
            pixels.push(match *px {
                [g] => [g, g, g],
                [g, a] => {
                    let c = over_white(g, a);
                    [c, c, c]
                }
                [r, g, b] => [r, g, b],
                [r, g, b, a] => [over_white(r, a), over_white(g, a), over_white(b, a)],
                _ => unreachable!("chunks_exact yields `channels` (1..=4) samples"),
            });
        }
    }
    RgbImage::new(w, h, pixels)
}

/// `c` with opacity `a` composited over white, rounded to nearest.
#[inline]
fn over_white(c: u8, a: u8) -> u8 {
    let (c, a) = (u32::from(c), u32::from(a));
    ((c * a + 255 * (255 - a) + 127) / 255) as u8
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Encodes `data` as a PNG of the given layout (test helper shared with
    /// the other chart modules).
    pub(crate) fn encode(
        width: u32,
        height: u32,
        color: png::ColorType,
        depth: png::BitDepth,
        palette: Option<&[u8]>,
        trns: Option<&[u8]>,
        data: &[u8],
    ) -> Vec<u8> {
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, width, height);
            enc.set_color(color);
            enc.set_depth(depth);
            if let Some(p) = palette {
                enc.set_palette(p.to_vec());
            }
            if let Some(t) = trns {
                enc.set_trns(t.to_vec());
            }
            let mut w = enc.write_header().unwrap();
            w.write_image_data(data).unwrap();
        }
        out
    }

    /// A 2 x 1 RGB PNG: red then blue.
    pub(crate) fn tiny_rgb() -> Vec<u8> {
        encode(
            2,
            1,
            png::ColorType::Rgb,
            png::BitDepth::Eight,
            None,
            None,
            &[255, 0, 0, 0, 0, 255],
        )
    }

    #[test]
    fn rgb8_round_trips() {
        let img = decode_png(&tiny_rgb()).unwrap();
        assert_eq!((img.width(), img.height()), (2, 1));
        assert_eq!(img.pixels(), &[[255, 0, 0], [0, 0, 255]]);
        assert_eq!(img.get(1, 0), Some([0, 0, 255]));
        assert_eq!(img.get(2, 0), None);
        assert_eq!(img.get(0, 1), None);
    }

    #[test]
    fn rows_are_stored_north_first() {
        // 1 x 2: top pixel white, bottom black.
        let png = encode(
            1,
            2,
            png::ColorType::Grayscale,
            png::BitDepth::Eight,
            None,
            None,
            &[255, 0],
        );
        let img = decode_png(&png).unwrap();
        assert_eq!(img.get(0, 0), Some([255; 3]));
        assert_eq!(img.get(0, 1), Some([0; 3]));
    }

    #[test]
    fn one_bit_greyscale_expands_to_black_and_white() {
        // 10 px wide so a row spans two bytes: 1010101010.
        let png = encode(
            10,
            1,
            png::ColorType::Grayscale,
            png::BitDepth::One,
            None,
            None,
            &[0b1010_1010, 0b1000_0000],
        );
        let img = decode_png(&png).unwrap();
        let expect: Vec<[u8; 3]> = (0..10).map(|i| if i % 2 == 0 { [255; 3] } else { [0; 3] }).collect();
        assert_eq!(img.pixels(), expect.as_slice());
    }

    #[test]
    fn sixteen_bit_rgb_keeps_the_high_byte() {
        let data = [0x12, 0x34, 0xAB, 0xCD, 0xFF, 0x00];
        let png = encode(1, 1, png::ColorType::Rgb, png::BitDepth::Sixteen, None, None, &data);
        assert_eq!(decode_png(&png).unwrap().pixels(), &[[0x12, 0xAB, 0xFF]]);
    }

    #[test]
    fn palette_expands_and_trns_composites_over_white() {
        let palette = [10, 20, 30, 200, 100, 50];
        // Index 1 fully transparent: reads as white paper.
        let trns = [255, 0];
        let png = encode(
            2,
            1,
            png::ColorType::Indexed,
            png::BitDepth::Eight,
            Some(&palette),
            Some(&trns),
            &[0, 1],
        );
        assert_eq!(decode_png(&png).unwrap().pixels(), &[[10, 20, 30], [255, 255, 255]]);
        let png = encode(
            2,
            1,
            png::ColorType::Indexed,
            png::BitDepth::Four,
            Some(&palette),
            None,
            &[0x10],
        );
        assert_eq!(decode_png(&png).unwrap().pixels(), &[[200, 100, 50], [10, 20, 30]]);
    }

    #[test]
    fn alpha_is_composited_over_white() {
        let png = encode(
            2,
            1,
            png::ColorType::Rgba,
            png::BitDepth::Eight,
            None,
            None,
            &[0, 0, 0, 255, 0, 100, 200, 0],
        );
        assert_eq!(decode_png(&png).unwrap().pixels(), &[[0, 0, 0], [255, 255, 255]]);
        let png = encode(
            1,
            1,
            png::ColorType::GrayscaleAlpha,
            png::BitDepth::Eight,
            None,
            None,
            &[0, 128],
        );
        // Half-opaque black over white: mid grey.
        assert_eq!(decode_png(&png).unwrap().pixels(), &[[127, 127, 127]]);
    }

    #[test]
    fn garbage_is_not_a_png() {
        assert_eq!(decode_png(b"hello world, not an image"), Err(ImageError::NotPng));
        assert_eq!(decode_png(&[]), Err(ImageError::NotPng));
    }

    #[test]
    fn truncated_png_is_corrupt_not_a_panic() {
        let png = tiny_rgb();
        // Cuts inside the header and inside the image data (a PNG cut only
        // in its trailing IEND still holds a whole image, and decodes).
        let idat_end = png.len() - 12;
        for cut in [8, 16, 33, 45, idat_end - 6, idat_end - 5] {
            match decode_png(&png[..cut]) {
                Err(ImageError::Corrupt(msg)) => assert!(!msg.is_empty()),
                other => panic!("cut at {cut}: {other:?}"),
            }
        }
        let mut flipped = png.clone();
        let n = flipped.len();
        flipped[n - 20] ^= 0xFF; // inside IDAT: CRC mismatch or bad zlib data
        assert!(matches!(decode_png(&flipped), Err(ImageError::Corrupt(_))));
    }

    #[test]
    fn zero_size_and_oversize_headers_are_rejected() {
        // A header claiming 0 x 1: hand-patch the IHDR of a valid 1 x 1 PNG
        // (width at bytes 16..20) and fix the CRC, which covers bytes 12..29.
        let patch = |w: u32, h: u32| {
            let mut png = encode(1, 1, png::ColorType::Rgb, png::BitDepth::Eight, None, None, &[1, 2, 3]);
            png[16..20].copy_from_slice(&w.to_be_bytes());
            png[20..24].copy_from_slice(&h.to_be_bytes());
            let crc = crc32(&png[12..29]);
            png[29..33].copy_from_slice(&crc.to_be_bytes());
            png
        };
        let got = decode_png(&patch(0, 1));
        assert!(
            matches!(got, Err(ImageError::ZeroSize { .. }) | Err(ImageError::Corrupt(_))),
            "{got:?}"
        );
        let got = decode_png(&patch(100_000, 100_000));
        assert!(matches!(got, Err(ImageError::TooLarge { .. })), "{got:?}");
        assert!(got.unwrap_err().to_string().contains("too large"));
    }

    #[test]
    fn new_validates_its_arguments() {
        assert!(matches!(RgbImage::new(0, 3, vec![]), Err(ImageError::ZeroSize { .. })));
        assert!(matches!(
            RgbImage::new(2, 2, vec![[0; 3]; 3]),
            Err(ImageError::Corrupt(_))
        ));
        assert!(matches!(
            RgbImage::new(usize::MAX, 2, vec![]),
            Err(ImageError::TooLarge { .. })
        ));
    }

    /// CRC-32 (PNG spec annex D), bitwise: only for patching test headers.
    fn crc32(bytes: &[u8]) -> u32 {
        let mut c = 0xFFFF_FFFFu32;
        for &b in bytes {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
            }
        }
        !c
    }
}
