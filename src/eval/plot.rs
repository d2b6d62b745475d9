//! Charts of an evaluation (plotters): rate–distortion curves (bitrate
//! against surface RMS and against the smoothness metric, log axes, one
//! curve per codec) and the error of every frame, so drift shows at a glance.
//! SVG or PNG, chosen by the file name; rendered in memory, so the caller
//! can write the file atomically.

use super::{EvalCodec, Report};
use crate::error::{Error, Result};
use plotters::coord::Shift;
use plotters::prelude::*;

fn err(e: impl std::fmt::Display) -> Error {
    Error::Plot(e.to_string())
}

/// plotters lays text out with a real font, even for SVG. We use the
/// system's (Debian: fonts-dejavu-core or fonts-liberation, which Chromium
/// pulls in) rather than ship one.
const FONTS: [&str; 4] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
];

fn register_font() -> Result<()> {
    static DONE: std::sync::OnceLock<std::result::Result<(), String>> = std::sync::OnceLock::new();
    DONE.get_or_init(|| {
        let bytes = FONTS.iter().find_map(|p| std::fs::read(p).ok()).ok_or_else(|| {
            format!("no TrueType font for the labels (looked for {}); install fonts-dejavu-core", FONTS.join(", "))
        })?;
        plotters::style::register_font("sans-serif", FontStyle::Normal, Box::leak(bytes.into_boxed_slice()))
            .map_err(|_| "the system font could not be read".to_string())
    })
    .clone()
    .map_err(Error::Plot)
}

fn color(c: EvalCodec) -> RGBColor {
    match c {
        EvalCodec::GV => RGBColor(214, 39, 40),
        EvalCodec::CONFORMAL => RGBColor(31, 119, 180),
        EvalCodec::PREDICTIVE => RGBColor(44, 160, 44),
        EvalCodec::NORMAL => RGBColor(23, 190, 207),
        EvalCodec::PREDICTIVE_SCALED => RGBColor(148, 103, 189),
        EvalCodec::PREDICTIVE_MOTION => RGBColor(255, 127, 14),
        EvalCodec::NORMAL_SCALED => RGBColor(140, 86, 75),
        EvalCodec::NORMAL_MOTION => RGBColor(227, 119, 194),
        // The named codecs above are all there are (EvalCodec's fields are private).
        _ => RGBColor(127, 127, 127),
    }
}

fn codecs(r: &Report) -> Vec<EvalCodec> {
    EvalCodec::NAMED.into_iter().filter(|c| r.points.iter().any(|p| p.results.iter().any(|x| x.codec == *c))).collect()
}

fn log_range(v: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for x in v.filter(|x| x.is_finite() && *x > 0.0) {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    if !lo.is_finite() {
        return 1e-6..1.0;
    }
    lo / 1.5..hi * 1.5
}

/// One log–log panel: kbit/s at 30 fps against `metric`.
fn rd_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    r: &Report,
    title: &str,
    metric: &dyn Fn(&super::CodecResult) -> Option<f64>,
    extra: &[Extra],
) -> Result<()> {
    let all = || r.points.iter().flat_map(|p| p.results.iter());
    let extra_points = || extra.iter().flat_map(|e| e.points.iter());
    let xr = log_range(all().map(|c| c.kbps_30fps).chain(extra_points().map(|p| p.0)));
    let yr = log_range(all().filter_map(metric).chain(extra_points().map(|p| p.1)));
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(xr.log_scale(), yr.log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("kbit/s at 30 fps")
        .y_desc("relative to the diagonal")
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(err)?;
    for c in codecs(r) {
        let pts: Vec<(f64, f64)> = r
            .points
            .iter()
            .flat_map(|p| p.results.iter().filter(|x| x.codec == c))
            .filter_map(|x| metric(x).map(|m| (x.kbps_30fps, m)))
            .collect();
        let col = color(c);
        chart
            .draw_series(LineSeries::new(pts.clone(), col.stroke_width(2)))
            .map_err(err)?
            .label(c.to_string())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, col.filled()))).map_err(err)?;
    }
    for e in extra {
        let col = e.color;
        chart
            .draw_series(DashedLineSeries::new(e.points.clone(), 6, 4, col.stroke_width(2)))
            .map_err(err)?
            .label(e.label.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
        chart.draw_series(e.points.iter().map(|&p| TriangleMarker::new(p, 5, col.filled()))).map_err(err)?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        // The peers' curves fall steeply to the lower right; our codecs' flatten there.
        .position(if extra.is_empty() { SeriesLabelPosition::UpperRight } else { SeriesLabelPosition::LowerLeft })
        .draw()
        .map_err(err)?;
    Ok(())
}

/// A dashed curve beside the codecs' own: a peer, or our file with its mesh.
struct Extra {
    label: String,
    color: RGBColor,
    points: Vec<(f64, f64)>,
}

const PEER_COLORS: [RGBColor; 4] =
    [RGBColor(127, 127, 127), RGBColor(140, 86, 75), RGBColor(227, 119, 194), RGBColor(23, 190, 207)];

/// The peers' surface RMS curves (`cgv eval --peers`), and ours as shipped
/// beside them (the motion and the input's mesh, as the peers carry it).
fn peer_curves(r: &Report) -> Vec<Extra> {
    let Some(p) = &r.peers else { return Vec::new() };
    let ours = r
        .points
        .iter()
        .flat_map(|q| q.results.iter().filter(|c| c.codec == p.codec))
        .filter_map(|c| c.surface_rms.map(|e| (super::peers::shipped_kbps_30fps(r, c), e)))
        .collect();
    let mut out =
        vec![Extra { label: format!("{} with the input's mesh", p.codec), color: color(p.codec), points: ours }];
    for (i, c) in p.report.curves.iter().enumerate() {
        let points = c.points.iter().filter_map(|q| q.surface_rms.map(|e| (q.kbps_30fps, e))).collect();
        out.push(Extra { label: c.name.clone(), color: PEER_COLORS[i % PEER_COLORS.len()], points });
    }
    out
}

fn draw_rd<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, r: &Report) -> Result<()> {
    root.fill(&WHITE).map_err(err)?;
    let panels = root.split_evenly((1, 2));
    let surface = r.points.iter().flat_map(|p| &p.results).any(|c| c.surface_rms.is_some());
    if surface {
        rd_panel(&panels[0], r, "surface RMS vs bitrate", &|c| c.surface_rms, &peer_curves(r))?;
    } else {
        rd_panel(&panels[0], r, "vertex RMS vs bitrate", &|c| Some(c.vertex_rms), &[])?;
    }
    rd_panel(&panels[1], r, "smoothness metric vs bitrate", &|c| Some(c.smoothness), &[])?;
    root.present().map_err(err)
}

fn draw_frames<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, r: &Report) -> Result<()> {
    root.fill(&WHITE).map_err(err)?;
    let rows = root.split_evenly((r.points.len().max(1), 1));
    for (p, area) in r.points.iter().zip(rows.iter()) {
        let surface = p.results.iter().any(|c| c.surface_rms.is_some());
        let value = |m: &super::FrameMetrics| if surface { m.surface_rms } else { Some(m.vertex_rms) };
        let yr = log_range(p.results.iter().flat_map(|c| c.frames.iter().filter_map(value)));
        let title = format!("{}: {} per frame", p.name, if surface { "surface RMS" } else { "vertex RMS" });
        let mut chart = ChartBuilder::on(area)
            .caption(title, ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(70)
            .build_cartesian_2d(0f64..r.frames.max(2) as f64 - 1.0, yr.log_scale())
            .map_err(err)?;
        chart.configure_mesh().x_desc("frame").y_label_formatter(&|v| format!("{v:.0e}")).draw().map_err(err)?;
        for c in &p.results {
            let col = color(c.codec);
            let pts: Vec<(f64, f64)> = c.frames.iter().filter_map(|m| value(m).map(|v| (m.frame as f64, v))).collect();
            chart
                .draw_series(LineSeries::new(pts, col.stroke_width(2)))
                .map_err(err)?
                .label(c.codec.to_string())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(err)?;
    }
    root.present().map_err(err)
}

/// Which chart.
#[derive(Debug, Clone, Copy)]
pub enum Chart {
    RateDistortion,
    PerFrame,
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, r: &Report, chart: Chart) -> Result<()> {
    match chart {
        Chart::RateDistortion => draw_rd(root, r),
        Chart::PerFrame => draw_frames(root, r),
    }
}

/// Renders `chart` as the bytes of an SVG (`png == false`) or PNG file.
pub fn render(r: &Report, chart: Chart, png: bool) -> Result<Vec<u8>> {
    register_font()?;
    let size = match chart {
        Chart::RateDistortion => (1200u32, 480u32),
        Chart::PerFrame => (1000, 220 * r.points.len().max(1) as u32),
    };
    if png {
        let mut rgb = vec![0u8; (size.0 * size.1 * 3) as usize];
        draw(BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area(), r, chart)?;
        let mut out = Vec::new();
        let mut enc = png::Encoder::new(&mut out, size.0, size.1);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(err)?;
        w.write_image_data(&rgb).map_err(err)?;
        w.finish().map_err(err)?;
        Ok(out)
    } else {
        let mut svg = String::new();
        draw(SVGBackend::with_string(&mut svg, size).into_drawing_area(), r, chart)?;
        Ok(svg.into_bytes())
    }
}
