//! `arbor bench --plot`: the comparison as a chart (plotters), grouped bars
//! of Mrays/s per accelerator and ray kind beside a bar chart of build times.
//!
//! SVG goes through plotters' SVG backend. PNG goes through [`CanvasBackend`],
//! a small plotters backend over arbor's RGB canvas whose text is arbor's
//! 5x7 bitmap font, so no system font or font-rendering crate is needed and
//! the picture is the same on every machine.

use std::convert::Infallible;
use std::path::Path;

use anyhow::anyhow;
use arbor::film::lowercase_extension;
use arbor::heatmap::{text_width, Canvas, GLYPH_HEIGHT, VIRIDIS};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendTextStyle, DrawingErrorKind, FontTransform,
};

use super::Report;
use crate::InputError;

/// Size of the chart in pixels.
const SIZE: (u32, u32) = (1100, 480);

/// The file types `--plot` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlotFormat {
    /// Scalable vector graphics.
    Svg,
    /// 8-bit RGB PNG.
    Png,
}

impl PlotFormat {
    /// The format named by `path`'s extension (any case).
    pub fn from_path(path: &Path) -> Result<PlotFormat, InputError> {
        match lowercase_extension(path).as_deref() {
            Some("svg") => Ok(PlotFormat::Svg),
            Some("png") => Ok(PlotFormat::Png),
            _ => Err(InputError(format!(
                "{}: --plot writes .svg or .png files",
                path.display()
            ))),
        }
    }
}

/// Draws `report` to `path` (written atomically).
pub fn draw(report: &Report, path: &Path) -> anyhow::Result<()> {
    match PlotFormat::from_path(path)? {
        PlotFormat::Svg => {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
                chart(&root, report).map_err(|e| anyhow!("{e}"))?;
                root.present().map_err(|e| anyhow!("{e}"))?;
            }
            arbor::film::atomic_write(path, |f| std::io::Write::write_all(f, svg.as_bytes()))?;
        }
        PlotFormat::Png => {
            let mut backend = CanvasBackend {
                canvas: Canvas::new(SIZE.0, SIZE.1, [255, 255, 255]),
            };
            {
                let root = (&mut backend).into_drawing_area();
                chart(&root, report).map_err(|e| anyhow!("{e}"))?;
                root.present().map_err(|e| anyhow!("{e}"))?;
            }
            backend.canvas.write_png(path)?;
        }
    }
    Ok(())
}

/// The colour of ray kind number `k` (viridis stops, readable in grey).
fn kind_colour(k: usize) -> RGBColor {
    let c = VIRIDIS[[1, 4, 7, 8][k % 4]];
    RGBColor(c[0], c[1], c[2])
}

/// Both charts on `root`.
/// The axes of a bar chart: values up the side (`y_desc`), no labels or
/// grid along the bars (they are labelled one by one).
fn bar_axes<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    y_desc: &str,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(0)
        .x_label_formatter(&|_| String::new())
        .y_desc(y_desc)
        .draw()
}

fn chart<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    report: &Report,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let (left, right) = root.split_horizontally(SIZE.0 * 7 / 10);
    let names: Vec<&str> = report.results.iter().map(|r| r.accel.name()).collect();
    let n = names.len().max(1) as f64;
    let input = Path::new(&report.input).file_name().map_or_else(
        || report.input.clone(),
        |f| f.to_string_lossy().into_owned(),
    );
    let kinds: Vec<&str> = report
        .results
        .first()
        .map(|r| r.rays.iter().map(|k| k.kind.name()).collect())
        .unwrap_or_default();

    // Mrays/s, grouped by accelerator, one bar per ray kind.
    let top = report
        .results
        .iter()
        .flat_map(|r| r.rays.iter().map(|k| k.mrays_per_s))
        .fold(0.0, f64::max);
    let top = if top > 0.0 { top * 1.15 } else { 1.0 };
    let mut speed = ChartBuilder::on(&left)
        .caption(
            format!(
                "{input}: Mrays/s ({} primitives, {} threads)",
                report.primitives, report.threads
            ),
            ("sans-serif", 18),
        )
        .margin(12)
        .x_label_area_size(30)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..n, 0.0..top)?;
    bar_axes(&mut speed, "Mrays/s")?;
    let width = 0.8 / kinds.len().max(1) as f64;
    for (k, kind) in kinds.iter().enumerate() {
        let colour = kind_colour(k);
        speed
            .draw_series(report.results.iter().enumerate().map(|(i, r)| {
                let x0 = i as f64 + 0.1 + k as f64 * width;
                let y = r.rays.get(k).map_or(0.0, |x| x.mrays_per_s);
                Rectangle::new([(x0, 0.0), (x0 + width * 0.92, y)], colour.filled())
            }))?
            .label(*kind)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], colour.filled()));
    }
    speed
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    for (i, name) in names.iter().enumerate() {
        let (x, y) = speed.backend_coord(&(i as f64 + 0.5, 0.0));
        root.draw(&Text::new(
            name.to_string(),
            (x, y + 8),
            TextStyle::from(("sans-serif", 12).into_font()).pos(Pos::new(HPos::Center, VPos::Top)),
        ))?;
    }

    // Build time per accelerator.
    let top = report
        .results
        .iter()
        .map(|r| r.build_ms)
        .fold(0.0, f64::max);
    let top = if top > 0.0 { top * 1.15 } else { 1.0 };
    let mut build = ChartBuilder::on(&right)
        .caption("build time", ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..n, 0.0..top)?;
    bar_axes(&mut build, "ms")?;
    let colour = kind_colour(3);
    build.draw_series(report.results.iter().enumerate().map(|(i, r)| {
        Rectangle::new(
            [(i as f64 + 0.15, 0.0), (i as f64 + 0.85, r.build_ms)],
            colour.filled(),
        )
    }))?;
    for (i, name) in names.iter().enumerate() {
        let (x, y) = build.backend_coord(&(i as f64 + 0.5, 0.0));
        // Alternate rows: the narrow chart has no room for every name on one.
        let dy = if i % 2 == 0 { 8 } else { 20 };
        root.draw(&Text::new(
            name.to_string(),
            (x, y + dy),
            TextStyle::from(("sans-serif", 10).into_font()).pos(Pos::new(HPos::Center, VPos::Top)),
        ))?;
    }
    Ok(())
}

/// A plotters backend drawing into an RGB [`Canvas`], with text in arbor's
/// bitmap font (scaled to the requested size in whole font pixels).
pub struct CanvasBackend {
    /// The picture drawn so far.
    pub canvas: Canvas,
}

impl CanvasBackend {
    /// Font pixels per glyph pixel for a plotters font size.
    fn scale(size: f64) -> u32 {
        ((size / 11.0).round() as u32).max(1)
    }
}

impl DrawingBackend for &mut CanvasBackend {
    type ErrorType = Infallible;

    fn get_size(&self) -> (u32, u32) {
        (self.canvas.width, self.canvas.height)
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Infallible>> {
        Ok(())
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Infallible>> {
        Ok(())
    }

    fn draw_pixel(
        &mut self,
        (x, y): BackendCoord,
        colour: BackendColor,
    ) -> Result<(), DrawingErrorKind<Infallible>> {
        if x < 0 || y < 0 {
            return Ok(());
        }
        let Some(old) = self.canvas.get(x as u32, y as u32) else {
            return Ok(());
        };
        // Alpha blending over what is there (legend backgrounds are translucent).
        let a = colour.alpha.clamp(0.0, 1.0);
        let (r, g, b) = colour.rgb;
        let mix = |new: u8, old: u8| (new as f64 * a + old as f64 * (1.0 - a)).round() as u8;
        self.canvas.set(
            x as i64,
            y as i64,
            [mix(r, old[0]), mix(g, old[1]), mix(b, old[2])],
        );
        Ok(())
    }

    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> Result<(u32, u32), DrawingErrorKind<Infallible>> {
        let s = CanvasBackend::scale(style.size());
        Ok((text_width(text, s), GLYPH_HEIGHT * s))
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        (x, y): BackendCoord,
    ) -> Result<(), DrawingErrorKind<Infallible>> {
        let s = CanvasBackend::scale(style.size());
        let c = style.color().rgb;
        let colour = [c.0, c.1, c.2];
        let vertical = !matches!(style.transform(), FontTransform::None);
        // Rotated text (axis titles) is stacked one character per line.
        let (w, h) = if vertical {
            (
                5 * s as i32,
                (text.chars().count() as u32 * (GLYPH_HEIGHT + 2) * s) as i32,
            )
        } else {
            (text_width(text, s) as i32, (GLYPH_HEIGHT * s) as i32)
        };
        let anchor = style.anchor();
        let dx = match anchor.h_pos {
            HPos::Left => 0,
            HPos::Center => -w / 2,
            HPos::Right => -w,
        };
        let dy = match anchor.v_pos {
            VPos::Top => 0,
            VPos::Center => -h / 2,
            VPos::Bottom => -h,
        };
        let (x0, y0) = ((x + dx) as i64, (y + dy) as i64);
        if vertical {
            for (i, ch) in text.chars().enumerate() {
                let mut buf = [0u8; 4];
                let step = ((GLYPH_HEIGHT + 2) * s) as i64;
                self.canvas.text(
                    x0,
                    y0 + i as i64 * step,
                    s,
                    ch.encode_utf8(&mut buf),
                    colour,
                );
            }
        } else {
            self.canvas.text(x0, y0, s, text, colour);
        }
        Ok(())
    }
}
