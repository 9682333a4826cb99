//! Cost heatmaps: how much traversal work each pixel's camera rays cost
//! (nodes visited plus primitive tests, both levels of the [`Tracer`]),
//! shown as a false-colour picture with a labelled colour bar.
//!
//! Everything is drawn by hand into an RGB [`Canvas`] (a nine-stop viridis
//! table, a 5x7 bitmap font), so the library needs no plotting or font
//! dependency and the output is the same on every machine.

use std::path::Path;

use arbor_accel::RayCounts;
use rayon::prelude::*;

use crate::film::{write_png, WriteError};
use crate::render::camera_ray;
use crate::scene::Scene;
use crate::tracer::Tracer;

/// The traversal cost of every pixel's camera rays.
#[derive(Clone, Debug, PartialEq)]
pub struct CostMap {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Nodes visited plus primitive tests, averaged over the pixel's camera
    /// rays, row by row from the top.
    pub cost: Vec<f64>,
}

impl CostMap {
    /// The largest pixel cost (0 for an empty map).
    pub fn max(&self) -> f64 {
        self.cost.iter().copied().fold(0.0, f64::max)
    }

    /// The mean pixel cost (0 for an empty map).
    pub fn mean(&self) -> f64 {
        if self.cost.is_empty() {
            0.0
        } else {
            self.cost.iter().sum::<f64>() / self.cost.len() as f64
        }
    }
}

/// The cost of the camera rays of every pixel of `scene` through `tracer`:
/// the same rays the renderer casts (every sample of every pixel, with the
/// integrator's `tmin`), counted with [`RayCounts`]. Secondary and shadow
/// rays are not included: the map shows where the structure is expensive to
/// enter, which is what differs between accelerators.
pub fn primary_cost(scene: &Scene, tracer: &Tracer) -> CostMap {
    let camera = scene.camera.prepare();
    let s = scene.samples_per_side;
    let (w, h) = (scene.width, scene.height);
    let cost: Vec<f64> = (0..h)
        .into_par_iter()
        .flat_map_iter(|row| {
            let camera = &camera;
            (0..w).map(move |col| {
                let mut counts = RayCounts::default();
                for a in 0..s {
                    for b in 0..s {
                        let ray = camera_ray(scene, camera, col, row, a, b);
                        tracer.closest_counted(&ray, &mut counts);
                    }
                }
                (counts.nodes + counts.tests) as f64 / (s * s).max(1) as f64
            })
        })
        .collect();
    CostMap {
        width: w,
        height: h,
        cost,
    }
}

/// Matplotlib's viridis at nine evenly spaced stops (perceptually uniform,
/// readable in grey and by colour-blind readers); interpolated linearly.
pub const VIRIDIS: [[u8; 3]; 9] = [
    [68, 1, 84],
    [72, 40, 120],
    [62, 74, 137],
    [49, 104, 142],
    [38, 130, 142],
    [31, 158, 137],
    [53, 183, 121],
    [109, 205, 89],
    [253, 231, 37],
];

/// The viridis colour of `t` in `[0, 1]` (clamped; NaN is the lowest colour).
pub fn viridis(t: f64) -> [u8; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let x = t * (VIRIDIS.len() - 1) as f64;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    std::array::from_fn(|c| (a[c] as f64 + (b[c] as f64 - a[c] as f64) * f).round() as u8)
}

/// The smallest of 1, 2, 5 times a power of ten that is at least `x`, so the
/// colour bar's labels are round numbers.
pub fn nice_ceiling(x: f64) -> f64 {
    if x.is_nan() || x <= 0.0 || !x.is_finite() {
        return 1.0;
    }
    let p = 10f64.powf(x.log10().floor());
    for m in [1.0, 2.0, 5.0, 10.0] {
        if m * p >= x * (1.0 - 1e-12) {
            return m * p;
        }
    }
    10.0 * p
}

/// An 8-bit RGB picture to draw into.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Canvas {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// RGB bytes, row by row from the top.
    pub rgb: Vec<u8>,
}

impl Canvas {
    /// A canvas filled with `colour`.
    pub fn new(width: u32, height: u32, colour: [u8; 3]) -> Canvas {
        let n = width as usize * height as usize;
        let mut rgb = Vec::with_capacity(3 * n);
        for _ in 0..n {
            rgb.extend_from_slice(&colour);
        }
        Canvas { width, height, rgb }
    }

    /// Sets one pixel; coordinates outside the canvas are ignored, so callers
    /// may draw shapes that overhang the edge.
    pub fn set(&mut self, x: i64, y: i64, colour: [u8; 3]) {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            return;
        }
        let i = 3 * (y as usize * self.width as usize + x as usize);
        self.rgb[i..i + 3].copy_from_slice(&colour);
    }

    /// The colour of one pixel, `None` outside the canvas.
    pub fn get(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = 3 * (y as usize * self.width as usize + x as usize);
        Some([self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]])
    }

    /// Fills the rectangle `x0..x1` by `y0..y1` (clipped to the canvas).
    pub fn fill_rect(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, colour: [u8; 3]) {
        for y in y0.max(0)..y1.min(self.height as i64) {
            for x in x0.max(0)..x1.min(self.width as i64) {
                self.set(x, y, colour);
            }
        }
    }

    /// Draws `text` with its top-left corner at `(x, y)` in the 5x7 font,
    /// each font pixel `scale` pixels wide. Lower case is drawn as upper case.
    pub fn text(&mut self, x: i64, y: i64, scale: u32, text: &str, colour: [u8; 3]) {
        let s = scale.max(1) as i64;
        for (k, ch) in text.chars().enumerate() {
            let glyph = glyph(ch);
            let gx = x + k as i64 * GLYPH_ADVANCE as i64 * s;
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..5 {
                    if bits & (0x10 >> col) != 0 {
                        let px = gx + col * s;
                        let py = y + row as i64 * s;
                        self.fill_rect(px, py, px + s, py + s, colour);
                    }
                }
            }
        }
    }

    /// Writes the canvas as an 8-bit RGB PNG (atomically).
    pub fn write_png(&self, path: &Path) -> Result<(), WriteError> {
        write_png(path, self.width, self.height, &self.rgb)
    }
}

/// Horizontal advance of one character of the bitmap font, in font pixels.
pub const GLYPH_ADVANCE: u32 = 6;
/// Height of one character of the bitmap font, in font pixels.
pub const GLYPH_HEIGHT: u32 = 7;

/// Width in pixels of `text` drawn at `scale` by [`Canvas::text`].
pub fn text_width(text: &str, scale: u32) -> u32 {
    let n = text.chars().count() as u32;
    if n == 0 {
        0
    } else {
        (n * GLYPH_ADVANCE - 1) * scale.max(1)
    }
}

/// The 5x7 bitmap of `ch`: seven rows, bit 4 the leftmost column.
fn glyph(ch: char) -> [u8; 7] {
    match ch.to_ascii_uppercase() {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        'A' => [0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'B' => [0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E],
        'C' => [0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E],
        'D' => [0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C],
        'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
        'F' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10],
        'G' => [0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F],
        'H' => [0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'I' => [0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'J' => [0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C],
        'K' => [0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F],
        'M' => [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11],
        'N' => [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11],
        'O' => [0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'P' => [0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10],
        'Q' => [0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D],
        'R' => [0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11],
        'S' => [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E],
        'T' => [0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        'U' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'V' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'W' => [0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A],
        'X' => [0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11],
        'Y' => [0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04],
        'Z' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F],
        '.' => [0, 0, 0, 0, 0, 0x0C, 0x0C],
        ',' => [0, 0, 0, 0, 0x0C, 0x04, 0x08],
        '-' => [0, 0, 0, 0x1F, 0, 0, 0],
        '+' => [0, 0x04, 0x04, 0x1F, 0x04, 0x04, 0],
        '=' => [0, 0, 0x1F, 0, 0x1F, 0, 0],
        '/' => [0, 0x01, 0x02, 0x04, 0x08, 0x10, 0],
        ':' => [0, 0x0C, 0x0C, 0, 0x0C, 0x0C, 0],
        '%' => [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03],
        '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
        ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
        '_' => [0, 0, 0, 0, 0, 0, 0x1F],
        ' ' => [0; 7],
        _ => [0x0E, 0x11, 0x01, 0x02, 0x04, 0, 0x04],
    }
}

/// Width of the panel right of the picture that holds the colour bar and
/// its labels.
pub const BAR_PANEL_WIDTH: u32 = 90;
/// Shortest canvas: below this the bar's five labels would overlap.
pub const MIN_HEIGHT: u32 = 120;
/// Width of the colour bar itself.
const BAR_WIDTH: i64 = 16;
/// Margin above and below the bar.
const BAR_MARGIN: i64 = 16;

/// Formats a colour bar label: whole numbers as such, others with one or
/// two decimals (costs below 10 are fractional on average).
fn label(v: f64) -> String {
    if (v - v.round()).abs() < 1e-9 {
        format!("{}", v.round() as i64)
    } else if v >= 1.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2}")
    }
}

/// The false-colour picture of `map`: the map itself at its own size on the
/// left (viridis from 0 to a round number at or above the largest cost), and
/// a [`BAR_PANEL_WIDTH`] wide panel on the right with the colour bar, five
/// labelled ticks and the caption "COST". The canvas is at least
/// [`MIN_HEIGHT`] tall (padded black below a shorter map).
pub fn heatmap_canvas(map: &CostMap) -> Canvas {
    let height = map.height.max(MIN_HEIGHT);
    let mut c = Canvas::new(map.width + BAR_PANEL_WIDTH, height, [0, 0, 0]);
    let top = nice_ceiling(map.max());
    for y in 0..map.height {
        for x in 0..map.width {
            let v = map.cost[(y * map.width + x) as usize];
            c.set(x as i64, y as i64, viridis(v / top));
        }
    }
    let white = [255, 255, 255];
    let bx = map.width as i64 + 10;
    let (y0, y1) = (BAR_MARGIN, height as i64 - BAR_MARGIN);
    let span = (y1 - y0 - 1).max(1) as f64;
    // The bar runs from the top value at y0 down to zero at y1 - 1.
    for y in y0..y1 {
        let t = 1.0 - (y - y0) as f64 / span;
        c.fill_rect(bx, y, bx + BAR_WIDTH, y + 1, viridis(t));
    }
    c.text(bx, 4, 1, "COST", white);
    for k in 0..=4 {
        let t = k as f64 / 4.0;
        let y = y1 - 1 - (t * span).round() as i64;
        c.fill_rect(bx + BAR_WIDTH, y, bx + BAR_WIDTH + 4, y + 1, white);
        c.text(
            bx + BAR_WIDTH + 6,
            y - (GLYPH_HEIGHT as i64) / 2,
            1,
            &label(t * top),
            white,
        );
    }
    c
}

/// Renders the cost map of `scene` through `tracer` and writes its
/// [`heatmap_canvas`] as a PNG to `path`; returns the map.
pub fn write_heatmap(scene: &Scene, tracer: &Tracer, path: &Path) -> Result<CostMap, WriteError> {
    let map = primary_cost(scene, tracer);
    heatmap_canvas(&map).write_png(path)?;
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viridis_ends_and_middle() {
        assert_eq!(viridis(0.0), VIRIDIS[0]);
        assert_eq!(viridis(1.0), VIRIDIS[8]);
        assert_eq!(viridis(0.5), VIRIDIS[4]);
        assert_eq!(viridis(-3.0), VIRIDIS[0]);
        assert_eq!(viridis(f64::NAN), VIRIDIS[0]);
        // Half-way between two stops is their average.
        let m = viridis(0.0625);
        assert_eq!(m, [70, 21, 102]);
    }

    #[test]
    fn nice_ceilings() {
        assert_eq!(nice_ceiling(0.0), 1.0);
        assert_eq!(nice_ceiling(1.0), 1.0);
        assert_eq!(nice_ceiling(1.2), 2.0);
        assert_eq!(nice_ceiling(37.0), 50.0);
        assert_eq!(nice_ceiling(180.0), 200.0);
        assert_eq!(nice_ceiling(600.0), 1000.0);
        assert_eq!(nice_ceiling(f64::NAN), 1.0);
    }

    #[test]
    fn canvas_has_bar_and_labels() {
        let map = CostMap {
            width: 40,
            height: 30,
            cost: (0..1200).map(|i| (i % 40) as f64).collect(),
        };
        let c = heatmap_canvas(&map);
        assert_eq!((c.width, c.height), (40 + BAR_PANEL_WIDTH, MIN_HEIGHT));
        // The largest cost (39) maps to 39/50 of the scale, the smallest to the bottom colour.
        assert_eq!(c.get(0, 0), Some(VIRIDIS[0]));
        assert_eq!(c.get(39, 0), Some(viridis(39.0 / 50.0)));
        // The bar: top colour at its top, bottom colour at its bottom.
        let bx = 40 + 10;
        assert_eq!(c.get(bx, BAR_MARGIN as u32), Some(VIRIDIS[8]));
        assert_eq!(
            c.get(bx, (MIN_HEIGHT as i64 - BAR_MARGIN - 1) as u32),
            Some(VIRIDIS[0])
        );
        // Some label text is drawn in white right of the bar.
        let white = (bx + 20..c.width)
            .flat_map(|x| (0..c.height).map(move |y| (x, y)))
            .filter(|&(x, y)| c.get(x, y) == Some([255, 255, 255]))
            .count();
        assert!(white > 50, "{white} white pixels");
    }

    #[test]
    fn labels_are_round() {
        assert_eq!(label(50.0), "50");
        assert_eq!(label(12.5), "12.5");
        assert_eq!(label(0.25), "0.25");
        assert_eq!(text_width("10", 1), 11);
        assert_eq!(text_width("", 3), 0);
    }
}
