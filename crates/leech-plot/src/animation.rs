//! Animated SVG (SMIL) of a moving body: open it in a web browser.
//!
//! Every frame's polylines become one `<animate attributeName="points">` per
//! polyline with discrete key times, so frames may have different numbers of
//! points (links appear while a tube is fed); a time stamp is shown frame by
//! frame. Coordinates are drawn in millimetres.

use std::fmt::Write as _;

/// One instant: its time and polylines (m), in drawing order.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Time (s).
    pub time: f64,
    /// Polylines (m).
    pub lines: Vec<Vec<[f64; 2]>>,
}

/// Style of each polyline: colour and width (px).
pub const STYLES: [(&str, f64); 4] = [("#0072b2", 2.0), ("#d55e00", 2.0), ("#009e73", 4.0), ("#5a5a5a", 5.0)];

pub(crate) fn points(line: &[[f64; 2]]) -> String {
    let mut s = String::new();
    for p in line {
        let _ = write!(s, "{:.3},{:.3} ", p[0] * 1e3, -p[1] * 1e3);
    }
    s.trim_end().to_string()
}

/// The drawing area of an animation, in SVG units (mm, y down): the box
/// `x0, y0, w, h` around the drawing, its larger extent `span` and the font size.
#[derive(Clone, Copy, Debug)]
pub(crate) struct View {
    pub x0: f64,
    pub y0: f64,
    pub w: f64,
    pub h: f64,
    pub span: f64,
    pub font: f64,
}

impl View {
    /// The box around `lo`..`hi` (mm, y up), padded by 12 % of its larger
    /// extent on every side; equal scales on x and y.
    pub(crate) fn around(lo: [f64; 2], hi: [f64; 2]) -> View {
        let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(10.0);
        let pad = 0.12 * span;
        // SVG y grows downwards: plot -y.
        View {
            x0: lo[0] - pad,
            y0: -hi[1] - pad,
            w: hi[0] - lo[0] + 2.0 * pad,
            h: hi[1] - lo[1] + 2.0 * pad,
            span,
            font: 0.03 * span,
        }
    }

    /// The box in metres, y up: (low corner, high corner).
    pub(crate) fn bounds_m(&self) -> ([f64; 2], [f64; 2]) {
        ([self.x0 * 1e-3, -(self.y0 + self.h) * 1e-3], [(self.x0 + self.w) * 1e-3, -self.y0 * 1e-3])
    }

    /// The document's opening: the `<svg>` element, a white background, the
    /// title (its lines stacked above the drawing), the axes through the
    /// origin and a 10 mm scale bar.
    pub(crate) fn open(&self, title: &str) -> String {
        let View { x0, y0, w, h, span, font } = *self;
        let title_space = (title.lines().count() as f64 * 1.3 + 0.5) * font;
        let mut svg = String::new();
        let _ = writeln!(
            svg,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="760" height="{:.0}" viewBox="{x0:.3} {:.3} {w:.3} {:.3}">"#,
            760.0 * (h + title_space) / w,
            y0 - title_space,
            h + title_space
        );
        let _ = writeln!(
            svg,
            r#"<rect x="{x0:.3}" y="{:.3}" width="{w:.3}" height="{:.3}" fill="white"/>"#,
            y0 - title_space,
            h + title_space
        );
        let lines_of_title: Vec<&str> = title.lines().collect();
        for (i, line) in lines_of_title.iter().enumerate() {
            let _ = writeln!(
                svg,
                r#"<text x="{:.3}" y="{:.3}" font-family="sans-serif" font-size="{font:.3}">{}</text>"#,
                x0 + 0.02 * w,
                y0 - (lines_of_title.len() - i) as f64 * 1.3 * font + 0.7 * font,
                xml_escape(line)
            );
        }
        let _ = writeln!(
            svg,
            r##"<g stroke="#cccccc" stroke-width="{:.3}"><line x1="{x0:.3}" y1="0" x2="{:.3}" y2="0"/><line x1="0" y1="{y0:.3}" x2="0" y2="{:.3}"/></g>"##,
            0.002 * span,
            x0 + w,
            y0 + h
        );
        let (bx, by) = (x0 + 0.05 * w, y0 + h - 0.05 * h);
        let _ = writeln!(
            svg,
            r#"<line x1="{bx:.3}" y1="{by:.3}" x2="{:.3}" y2="{by:.3}" stroke="black" stroke-width="{:.3}"/><text x="{bx:.3}" y="{:.3}" font-family="sans-serif" font-size="{:.3}">10 mm (g points down)</text>"#,
            bx + 10.0,
            0.006 * span,
            by - 0.4 * font,
            0.8 * font
        );
        svg
    }
}

/// The animation as an SVG document. `frames` must not be empty.
pub fn animated_svg(title: &str, frames: &[Frame]) -> String {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in frames.iter().flat_map(|f| f.lines.iter().flatten()) {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k] * 1e3);
            hi[k] = hi[k].max(p[k] * 1e3);
        }
    }
    let view = View::around(lo, hi);
    let View { x0, y0, w, h, span, font } = view;
    let duration = frames.last().map_or(1.0, |f| f.time).max(1e-3);
    let mut svg = view.open(title);
    let lines = frames.iter().map(|f| f.lines.len()).max().unwrap_or(0);
    let key_times: Vec<String> = frames.iter().map(|f| format!("{:.6}", f.time / duration)).collect();
    for l in 0..lines {
        let (color, width) = STYLES[l.min(STYLES.len() - 1)];
        let values: Vec<String> =
            frames.iter().map(|f| f.lines.get(l).map(|p| points(p)).unwrap_or_default()).collect();
        let _ = writeln!(
            svg,
            r#"<polyline fill="none" stroke="{color}" stroke-width="{:.3}" points="{}"><animate attributeName="points" calcMode="discrete" dur="{duration:.6}s" fill="freeze" keyTimes="{}" values="{}"/></polyline>"#,
            width * span / 760.0,
            values[0],
            key_times.join(";"),
            values.join(";")
        );
    }
    for (i, f) in frames.iter().enumerate() {
        let end = frames.get(i + 1).map(|n| format!(r#" end="{:.6}s""#, n.time)).unwrap_or_default();
        // The first stamp is visible from the start, so that a still
        // rendering (a viewer without SMIL) shows the initial state labelled.
        let initial = if i == 0 { "visible" } else { "hidden" };
        let _ = writeln!(
            svg,
            r#"<text x="{:.3}" y="{:.3}" font-family="sans-serif" font-size="{font:.3}" visibility="{initial}">t = {:.3} s<set attributeName="visibility" to="visible" begin="{:.6}s"{end}/>{}</text>"#,
            x0 + 0.02 * w,
            y0 + 0.04 * h,
            f.time,
            f.time,
            if i == 0 && frames.len() > 1 {
                format!(r#"<set attributeName="visibility" to="hidden" begin="{:.6}s"/>"#, frames[1].time)
            } else {
                String::new()
            }
        );
    }
    svg.push_str("</svg>\n");
    svg
}

pub(crate) fn xml_escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}
