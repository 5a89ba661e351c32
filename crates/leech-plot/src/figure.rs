//! Figures in physical units: data in metres, axes in millimetres.

use std::path::Path;
use std::sync::Once;

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

/// Errors while drawing or writing a picture.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The drawing backend failed.
    #[error("drawing failed: {0}")]
    Draw(String),
    /// The picture could not be written.
    #[error("cannot write {path}: {message}")]
    Write {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// Nothing to draw, or a non-finite coordinate.
    #[error("nothing finite to draw")]
    Empty,
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SeriesStyle {
    /// A line with a dot at every point (a chain and its joints).
    LineAndDots,
    /// A plain line.
    Line,
    /// A thick line (a plate, the driving unit).
    Thick,
    /// Dots only.
    Dots,
    /// A dashed line (a kinematic model beside a physical one).
    Dashed,
    /// A closed polygon, filled lightly (a reachable region, a solid).
    Area,
    /// An arrow from the second-to-last point to the last (a force).
    Arrow,
}

/// How data in metres is shown on the axes.
#[derive(Clone, Debug, PartialEq)]
pub struct Axes {
    /// Multiplier from data to axis units (1000 for mm).
    pub scale: f64,
    /// Horizontal axis title.
    pub x_label: String,
    /// Vertical axis title.
    pub y_label: String,
}

impl Default for Axes {
    fn default() -> Self {
        Axes { scale: 1e3, x_label: "x (mm)".into(), y_label: "y (mm)".into() }
    }
}

/// One labelled polyline, in metres.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend text; empty for none.
    pub label: String,
    /// Points (m).
    pub points: Vec<[f64; 2]>,
    /// Drawing style.
    pub style: SeriesStyle,
    /// Colour as RGB.
    pub color: (u8, u8, u8),
}

/// A picture: title, series, axes in mm with equal scales.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    /// Title at the top.
    pub title: String,
    /// The series, drawn in order.
    pub series: Vec<Series>,
    /// Draw an arrow showing gravity (-y) in a corner.
    pub gravity_arrow: bool,
    /// Size in pixels (width, height).
    pub size: (u32, u32),
    /// Axis units and titles (mm by default).
    pub axes: Axes,
    /// Panels drawn side by side under the title, each with its own axes,
    /// all at one scale (a body's views); a figure with panels draws them
    /// instead of its own series. Each panel's title is its caption; its
    /// size is unused (the figure's is split evenly).
    pub panels: Vec<Figure>,
}

/// Colours that stay distinguishable in print and for common colour blindness.
pub const PALETTE: [(u8, u8, u8); 6] =
    [(0, 114, 178), (213, 94, 0), (0, 158, 115), (204, 121, 167), (86, 180, 233), (230, 159, 0)];

const FONT: &str = "sans-serif";

/// Space around a chart, for its tick labels and for a caption (pixels).
const MARGIN: u32 = 12;
const X_LABELS: u32 = 45;
const Y_LABELS: u32 = 60;
const CAPTION: u32 = 34;

/// Tick labels across a figure, and across a panel (narrower).
const X_TICKS: usize = 10;
const PANEL_X_TICKS: usize = 6;

/// The plotting area (pixels) of a chart drawn on an area of `(w, h)` pixels.
fn plot_size((w, h): (u32, u32)) -> (f64, f64) {
    (
        w.saturating_sub(2 * MARGIN + Y_LABELS).max(1) as f64,
        h.saturating_sub(2 * MARGIN + X_LABELS + CAPTION).max(1) as f64,
    )
}

/// An arrow head's length as a fraction of the plot's width.
const ARROW_HEAD: f64 = 0.022;

/// The chart a figure draws on: axes in axis units.
type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

fn draw_error<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// A filled arrow head with its tip at `tip`, pointing along `direction`,
/// `length` long (axis units).
fn arrow_head(tip: (f64, f64), direction: (f64, f64), length: f64, color: RGBColor) -> Polygon<(f64, f64)> {
    let norm = direction.0.hypot(direction.1).max(f64::MIN_POSITIVE);
    let (ux, uy) = (direction.0 / norm, direction.1 / norm);
    let base = (tip.0 - length * ux, tip.1 - length * uy);
    let half = 0.4 * length;
    Polygon::new(
        vec![tip, (base.0 - half * uy, base.1 + half * ux), (base.0 + half * uy, base.1 - half * ux)],
        color.filled(),
    )
}

/// The arrow showing gravity (-y) in corner `corner` of the plot.
fn gravity_arrow<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    corner: usize,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let len = (y1 - y0) * 0.08;
    let x = if corner.is_multiple_of(2) { x0 + (x1 - x0) * 0.06 } else { x1 - (x1 - x0) * 0.06 };
    let y = if corner < 2 { y1 - (y1 - y0) * 0.04 } else { y0 + (y1 - y0) * 0.04 + len };
    let black = BLACK.stroke_width(2);
    chart.draw_series(std::iter::once(PathElement::new(vec![(x, y), (x, y - len)], black))).map_err(draw_error)?;
    chart.draw_series(std::iter::once(arrow_head((x, y - len), (0.0, -1.0), len * 0.3, BLACK))).map_err(draw_error)?;
    chart
        .draw_series(std::iter::once(Text::new("g", (x + (x1 - x0) * 0.012, y - len * 0.3), (FONT, 16))))
        .map_err(draw_error)?;
    Ok(())
}

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The embedded font is valid; a failure here would be a packaging bug.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
    });
}

impl Figure {
    /// An empty figure with a title.
    pub fn new(title: impl Into<String>) -> Figure {
        Figure {
            title: title.into(),
            series: Vec::new(),
            gravity_arrow: false,
            size: (760, 760),
            axes: Axes::default(),
            panels: Vec::new(),
        }
    }

    /// A figure of `panels` side by side under `title`, each `panel_size`
    /// pixels (width, height) below the title.
    pub fn row(title: impl Into<String>, panels: Vec<Figure>, panel_size: (u32, u32)) -> Figure {
        let mut fig = Figure::new(title);
        fig.size = (panel_size.0 * panels.len().max(1) as u32, panel_size.1 + CAPTION);
        fig.panels = panels;
        fig
    }

    /// Adds a series.
    pub fn push(&mut self, label: impl Into<String>, points: Vec<[f64; 2]>, style: SeriesStyle, color: (u8, u8, u8)) {
        self.series.push(Series { label: label.into(), points, style, color });
    }

    /// Axis units per pixel that show the padded data in a plotting area of
    /// `plot` pixels (width, height), the same across as up.
    fn units_per_px(&self, plot: (f64, f64)) -> Result<f64, PlotError> {
        let (lo, hi) = self.extent()?;
        let least = 1e-3 * self.axes.scale;
        let span = [(hi[0] - lo[0]).max(least) * 1.2, (hi[1] - lo[1]).max(least) * 1.2];
        Ok((span[0] / plot.0).max(span[1] / plot.1))
    }

    /// Bounds in axis units of a plotting area of `plot` pixels at
    /// `per_px` axis units a pixel, centred on the data.
    fn bounds_at(&self, plot: (f64, f64), per_px: f64) -> Result<((f64, f64), (f64, f64)), PlotError> {
        let (lo, hi) = self.extent()?;
        let span = [plot.0 * per_px, plot.1 * per_px];
        let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        Ok((
            (centre[0] - span[0] / 2.0, centre[0] + span[0] / 2.0),
            (centre[1] - span[1] / 2.0, centre[1] + span[1] / 2.0),
        ))
    }

    /// The data's lower and upper corners in axis units.
    fn extent(&self) -> Result<([f64; 2], [f64; 2]), PlotError> {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for p in self.series.iter().flat_map(|s| s.points.iter()) {
            if !(p[0].is_finite() && p[1].is_finite()) {
                return Err(PlotError::Empty);
            }
            for k in 0..2 {
                lo[k] = lo[k].min(p[k] * self.axes.scale);
                hi[k] = hi[k].max(p[k] * self.axes.scale);
            }
        }
        if !lo[0].is_finite() {
            return Err(PlotError::Empty);
        }
        Ok((lo, hi))
    }

    /// Corners of the plotting area ranked from the emptiest: the legend and
    /// the gravity arrow go where they hide no data.
    fn corners_by_emptiness(&self, x: (f64, f64), y: (f64, f64)) -> Vec<usize> {
        let corner = |i: usize| {
            let cx = if i.is_multiple_of(2) { x.0 + 0.2 * (x.1 - x.0) } else { x.1 - 0.2 * (x.1 - x.0) };
            let cy = if i < 2 { y.1 - 0.12 * (y.1 - y.0) } else { y.0 + 0.12 * (y.1 - y.0) };
            (cx, cy)
        };
        let clearance = |i: usize| {
            let (cx, cy) = corner(i);
            self.series
                .iter()
                .flat_map(|s| s.points.iter())
                .map(|p| {
                    let (px, py) = (p[0] * self.axes.scale, p[1] * self.axes.scale);
                    ((px - cx) / (x.1 - x.0)).powi(2) + ((py - cy) / (y.1 - y.0)).powi(2)
                })
                .fold(f64::INFINITY, f64::min)
        };
        let mut order: Vec<usize> = (0..4).collect();
        order.sort_by(|a, b| clearance(*b).total_cmp(&clearance(*a)));
        order
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        register_font();
        root.fill(&WHITE).map_err(draw_error)?;
        if self.panels.is_empty() {
            let plot = plot_size(root.dim_in_pixel());
            self.draw_chart(&root, self.bounds_at(plot, self.units_per_px(plot)?)?, X_TICKS)?;
        } else {
            let below = root.titled(&self.title, (FONT, 20)).map_err(draw_error)?;
            let areas = below.split_evenly((1, self.panels.len()));
            let plots: Vec<(f64, f64)> = areas.iter().map(|a| plot_size(a.dim_in_pixel())).collect();
            // One scale for every panel: the coarsest any of them needs.
            let mut per_px = 0.0f64;
            for (panel, plot) in self.panels.iter().zip(&plots) {
                per_px = per_px.max(panel.units_per_px(*plot)?);
            }
            for ((panel, area), plot) in self.panels.iter().zip(&areas).zip(plots) {
                panel.draw_chart(area, panel.bounds_at(plot, per_px)?, PANEL_X_TICKS)?;
            }
        }
        root.present().map_err(draw_error)?;
        Ok(())
    }

    /// The chart of this figure's series on `area`, over `bounds` (axis
    /// units) with at most `x_ticks` labels across, its title the caption;
    /// the legend only when a series has a label.
    fn draw_chart<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        ((x0, x1), (y0, y1)): ((f64, f64), (f64, f64)),
        x_ticks: usize,
    ) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let mut chart = ChartBuilder::on(area)
            .caption(&self.title, (FONT, 20))
            .margin(MARGIN)
            .x_label_area_size(X_LABELS)
            .y_label_area_size(Y_LABELS)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(draw_error)?;
        chart
            .configure_mesh()
            .x_labels(x_ticks)
            .x_desc(self.axes.x_label.as_str())
            .y_desc(self.axes.y_label.as_str())
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 15))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(draw_error)?;
        // Arrow heads in axis units: the same size on the page whatever the arrow's length.
        let head = ARROW_HEAD * (x1 - x0);
        for s in &self.series {
            self.draw_series(&mut chart, s, head)?;
        }
        let corners = self.corners_by_emptiness((x0, x1), (y0, y1));
        if self.gravity_arrow {
            gravity_arrow(&mut chart, corners[1], (x0, x1), (y0, y1))?;
        }
        if self.series.iter().all(|s| s.label.is_empty()) {
            return Ok(());
        }
        let position = match corners[0] {
            0 => SeriesLabelPosition::UpperLeft,
            1 => SeriesLabelPosition::UpperRight,
            2 => SeriesLabelPosition::LowerLeft,
            _ => SeriesLabelPosition::LowerRight,
        };
        chart
            .configure_series_labels()
            .label_font((FONT, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(180, 180, 180))
            .position(position)
            .draw()
            .map_err(draw_error)
    }

    /// One series, with its legend entry when it has a label; `head` is the
    /// length of an arrow head (axis units).
    fn draw_series<DB: DrawingBackend>(&self, chart: &mut Chart<'_, DB>, s: &Series, head: f64) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        let color = RGBColor(s.color.0, s.color.1, s.color.2);
        let scale = self.axes.scale;
        let mm: Vec<(f64, f64)> = s.points.iter().map(|p| (p[0] * scale, p[1] * scale)).collect();
        let width = match s.style {
            SeriesStyle::Thick => 4,
            _ => 2,
        };
        let drawn = match s.style {
            SeriesStyle::Dots => {
                chart.draw_series(mm.iter().map(|p| Circle::new(*p, 3, color.filled()))).map_err(draw_error)?
            }
            SeriesStyle::Dashed => chart
                .draw_series(DashedLineSeries::new(mm.clone(), 6, 4, color.stroke_width(width)))
                .map_err(draw_error)?,
            SeriesStyle::Area => chart
                .draw_series(std::iter::once(Polygon::new(mm.clone(), color.mix(0.25).filled())))
                .map_err(draw_error)?,
            SeriesStyle::Arrow if mm.len() >= 2 => {
                let (from, to) = (mm[mm.len() - 2], mm[mm.len() - 1]);
                let length = (to.0 - from.0).hypot(to.1 - from.1);
                let tip = arrow_head(to, (to.0 - from.0, to.1 - from.1), head.min(0.5 * length), color);
                chart.draw_series(std::iter::once(tip)).map_err(draw_error)?;
                chart.draw_series(LineSeries::new(mm.clone(), color.stroke_width(width))).map_err(draw_error)?
            }
            _ => chart.draw_series(LineSeries::new(mm.clone(), color.stroke_width(width))).map_err(draw_error)?,
        };
        if !s.label.is_empty() {
            drawn
                .label(s.label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(width)));
        }
        if s.style == SeriesStyle::LineAndDots {
            chart.draw_series(mm.iter().map(|p| Circle::new(*p, 2, color.filled()))).map_err(draw_error)?;
        }
        Ok(())
    }

    /// The figure as an SVG document.
    pub fn to_svg_string(&self) -> Result<String, PlotError> {
        let mut out = String::new();
        {
            let root = SVGBackend::with_string(&mut out, self.size).into_drawing_area();
            self.draw(root)?;
        }
        Ok(out)
    }

    /// Writes the figure as SVG.
    pub fn write_svg(&self, path: &Path) -> Result<(), PlotError> {
        let svg = self.to_svg_string()?;
        std::fs::write(path, svg)
            .map_err(|e| PlotError::Write { path: path.display().to_string(), message: e.to_string() })
    }

    /// Writes the figure as PNG, whatever the path's name: drawn in memory,
    /// encoded, then written in one go, so a failed write is the system's
    /// one-line reason (`No space left on device`).
    pub fn write_png(&self, path: &Path) -> Result<(), PlotError> {
        use image::ImageEncoder;
        let (w, h) = self.size;
        let mut rgb = vec![0u8; w as usize * h as usize * 3];
        self.draw(BitMapBackend::with_buffer(&mut rgb, self.size).into_drawing_area())?;
        let mut png = Vec::new();
        image::codecs::png::PngEncoder::new(&mut png)
            .write_image(&rgb, w, h, image::ColorType::Rgb8)
            .map_err(|e| PlotError::Draw(e.to_string()))?;
        std::fs::write(path, png)
            .map_err(|e| PlotError::Write { path: path.display().to_string(), message: e.to_string() })
    }
}
