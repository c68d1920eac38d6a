//! `cobalt bench --plots DIR`: charts in the manner of the thesis: Figure 4.1 (rendering
//! efficiency, MRays/s) and Figure 4.2 (balance efficiency) as bars of regular and cost-based
//! runs per policy and task size, the estimators' trade of Table 4.1 judged by time (error
//! against measured task times over net overhead, per walk and sampling rate, with the LPT
//! balance each buys), and the cost image of Figure 3.2.
//!
//! Text is drawn from a TrueType font read at run time (`$COBALT_FONT`, else DejaVu Sans from
//! Debian's `fonts-dejavu-core`), so no font library is linked; without one, `--plots` says
//! what to install instead of drawing unlabelled charts.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;
use plotters::style::FontStyle;

use crate::error::CliError;
use raytrace::bench::{Record, TradePoint};

const FONTS: [&str; 2] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
];

/// Registers the chart font once; the error says where it was looked for.
fn font() -> Result<(), CliError> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        let candidates: Vec<PathBuf> = std::env::var_os("COBALT_FONT")
            .map(PathBuf::from)
            .into_iter()
            .chain(FONTS.iter().map(PathBuf::from))
            .collect();
        let (path, bytes) = candidates
            .iter()
            .find_map(|p| std::fs::read(p).ok().map(|b| (p, b)))
            .ok_or_else(|| {
                format!(
                    "--plots needs a TrueType font: none at {}; install fonts-dejavu-core or set \
                     COBALT_FONT to a .ttf file",
                    candidates
                        .iter()
                        .map(|p| p.display().to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })?;
        // The font lives as long as the process: plotters keeps a `&'static` to it.
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
            .map_err(|_| format!("{}: not a usable TrueType font", path.display()))
    })
    .clone()
    .map_err(CliError::Write)
}

const W: u32 = 1200;
const PANEL_H: u32 = 420;

fn draw_err<E: std::fmt::Debug>(e: E) -> CliError {
    CliError::Write(format!("drawing a chart: {e:?}"))
}

/// Draws a chart of `w × h` pixels on white with `draw`, and writes it to `path` as PNG.
fn chart(
    path: &Path,
    (w, h): (u32, u32),
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), CliError>,
) -> Result<(), CliError> {
    use image::ImageEncoder;
    let mut rgb = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        draw(&root)?;
        root.present().map_err(draw_err)?;
    }
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(&rgb, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| CliError::Write(format!("{}: {e}", path.display())))?;
    crate::output::write_file(path, &png)
}

/// The legend of a chart's series, in its corner.
fn legend<'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, BitMapBackend<'a>, CT>,
) -> Result<(), CliError> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(draw_err)
}

fn policy_abbrev(p: &str) -> &'static str {
    match p {
        "static-equal" => "EQUAL",
        "static-lpt" => "LPT",
        "queue-fifo" => "FIFO",
        "queue-sorted" => "SORTED",
        "hybrid" => "HYBRID",
        _ => "?",
    }
}

/// Bars of `metric` for each (task size, policy), regular beside cost-based, one panel per
/// scene and shader.
fn bars(
    path: &Path,
    records: &[Record],
    title: &str,
    unit: &str,
    metric: impl Fn(&Record) -> f64,
) -> Result<(), CliError> {
    let mut panels: Vec<(String, &'static str)> = Vec::new();
    for r in records {
        if !panels.iter().any(|(s, w)| *s == r.scene && *w == r.shader) {
            panels.push((r.scene.clone(), r.shader));
        }
    }
    let h = PANEL_H * panels.len().max(1) as u32;
    chart(path, (W, h), |root| {
        for (area, (scene, shader)) in root
            .split_evenly((panels.len().max(1), 1))
            .iter()
            .zip(&panels)
        {
            let mine: Vec<&Record> = records
                .iter()
                .filter(|r| r.scene == *scene && r.shader == *shader)
                .collect();
            let mut groups: Vec<(usize, &'static str)> = Vec::new();
            for r in &mine {
                if !groups.contains(&(r.task_size, r.policy)) {
                    groups.push((r.task_size, r.policy));
                }
            }
            let top = mine.iter().map(|r| metric(r)).fold(0.0, f64::max) * 1.15 + 1e-9;
            let n = groups.len() as i32;
            let mut chart = ChartBuilder::on(area)
                .caption(format!("{title}: {scene}, {shader}"), ("sans-serif", 20))
                .margin(12)
                .x_label_area_size(36)
                .y_label_area_size(64)
                .build_cartesian_2d(0..3 * n, 0.0..top)
                .map_err(draw_err)?;
            let labels = groups.clone();
            chart
                .configure_mesh()
                .disable_x_mesh()
                .x_labels((3 * n) as usize + 1)
                .x_label_formatter(&|x| {
                    let g = (*x / 3) as usize;
                    match labels.get(g) {
                        Some((size, p)) if x % 3 == 1 => {
                            let size = if size % 1024 == 0 {
                                format!("{}k", size / 1024)
                            } else {
                                size.to_string()
                            };
                            format!("{} {size}", policy_abbrev(p))
                        }
                        _ => String::new(),
                    }
                })
                .y_desc(unit)
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(draw_err)?;
            for (mode, colour, offset) in [
                ("regular", RGBColor(170, 170, 170), 0),
                ("cost", RGBColor(40, 90, 200), 1),
            ] {
                let series = groups.iter().enumerate().filter_map(|(g, (size, p))| {
                    mine.iter()
                        .find(|r| r.task_size == *size && r.policy == *p && r.mode == mode)
                        .map(|r| {
                            let x = 3 * g as i32 + offset;
                            Rectangle::new([(x, 0.0), (x + 1, metric(r))], colour.filled())
                        })
                });
                chart
                    .draw_series(series)
                    .map_err(draw_err)?
                    .label(mode)
                    .legend(move |(x, y)| {
                        Rectangle::new([(x, y - 6), (x + 12, y + 6)], colour.filled())
                    });
            }
            legend(&mut chart)?;
        }
        Ok(())
    })
}

/// The estimators' trade: error against measured time over net overhead, one line per ray kind
/// and walk, points labelled by sampling rate and by the balance an LPT plan on 8 devices by
/// those estimates reaches (judged by the measured task times): the first scene's, at tasks of
/// 4096 rays if measured (else the first size).
fn trade(path: &Path, points: &[TradePoint]) -> Result<(), CliError> {
    let Some(first) = points.first() else {
        return Ok(());
    };
    let size = points
        .iter()
        .map(|p| p.task_size)
        .find(|&t| t == 4096)
        .unwrap_or(first.task_size);
    let points: Vec<&TradePoint> = points
        .iter()
        .filter(|p| p.scene == first.scene && p.task_size == size)
        .collect();
    chart(path, (900, 560), |root| {
        // Net overheads can be negative (a sample traced for real can cost less than the
        // rays it saves): the axis starts below the least.
        let xmin = points
            .iter()
            .map(|p| 100.0 * p.figures.net_overhead)
            .fold(0.0, f64::min)
            * 1.15;
        let xmax = points
            .iter()
            .map(|p| 100.0 * p.figures.net_overhead)
            .fold(0.0, f64::max)
            * 1.15
            + 1e-9;
        let ymax = points
            .iter()
            .filter_map(|p| p.figures.error_vs_time)
            .map(|e| 100.0 * e)
            .fold(0.0, f64::max)
            * 1.25
            + 0.5;
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!(
                    "Estimators: error vs time over net overhead ({}, tasks of {size} rays)",
                    first.scene
                ),
                ("sans-serif", 20),
            )
            .margin(14)
            .x_label_area_size(44)
            .y_label_area_size(60)
            .build_cartesian_2d(xmin..xmax, 0.0..ymax)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("net estimation overhead, % of the full trace")
            .y_desc("error vs measured task time, %")
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(draw_err)?;
        let mut walks: Vec<&str> = points.iter().map(|p| p.figures.walk).collect();
        walks.sort_unstable();
        walks.dedup();
        let lines = [
            ("coherent", RGBColor(40, 90, 200)),
            ("diffuse", RGBColor(210, 90, 30)),
        ]
        .into_iter()
        .flat_map(|k| walks.iter().map(move |&walk| (k, walk)));
        for ((kind, base), walk) in lines {
            // The real trace's walk drawn darker than the reduced traversals.
            let colour = if walk == "trace" {
                RGBColor(base.0 / 2, base.1 / 2, base.2 / 2)
            } else {
                base
            };
            let pts: Vec<(f64, f64, String)> = points
                .iter()
                .filter(|p| p.ray_kind == kind && p.figures.walk == walk)
                .filter_map(|p| {
                    let rate = format!("{:.1} %", 100.0 * p.sample_rate);
                    let label = match p.lpt_balance {
                        Some(b) => format!("{rate}, LPT {:.1} %", 100.0 * b),
                        None => rate,
                    };
                    Some((
                        100.0 * p.figures.net_overhead,
                        100.0 * p.figures.error_vs_time?,
                        label,
                    ))
                })
                .collect();
            if pts.is_empty() {
                continue;
            }
            chart
                .draw_series(LineSeries::new(
                    pts.iter().map(|(x, y, _)| (*x, *y)),
                    colour.stroke_width(2),
                ))
                .map_err(draw_err)?
                .label(format!("{kind}, {walk}"))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(pts.iter().map(|(x, y, label)| {
                    EmptyElement::at((*x, *y))
                        + Circle::new((0, 0), 4, colour.filled())
                        + Text::new(label.clone(), (6, -16), ("sans-serif", 13))
                }))
                .map_err(draw_err)?;
        }
        legend(&mut chart)?;
        Ok(())
    })
}

/// The charts `--plots` may write into its directory, in the order [`write_all`] writes them:
/// MRays/s, balance, the sampling trade, the cost image.
pub const FILES: [&str; 4] = ["mrays.png", "balance.png", "sampling.png", "cost.png"];

/// Writes every chart into `dir` (created if missing); returns the files written.
pub fn write_all(
    dir: &Path,
    records: &[Record],
    points: &[TradePoint],
    cost_png: Option<Vec<u8>>,
) -> Result<Vec<PathBuf>, CliError> {
    font()?;
    std::fs::create_dir_all(dir).map_err(|e| CliError::Write(format!("{}: {e}", dir.display())))?;
    let mut written = Vec::new();
    let p = dir.join(FILES[0]);
    bars(
        &p,
        records,
        "Rendering efficiency (thesis Fig. 4.1)",
        "MRays/s",
        |r| r.mrays_per_s,
    )?;
    written.push(p);
    let p = dir.join(FILES[1]);
    bars(
        &p,
        records,
        "Balance efficiency (thesis Fig. 4.2)",
        "balance, %",
        |r| 100.0 * r.balance_efficiency,
    )?;
    written.push(p);
    if !points.is_empty() {
        let p = dir.join(FILES[2]);
        trade(&p, points)?;
        written.push(p);
    }
    if let Some(png) = cost_png {
        let p = dir.join(FILES[3]);
        crate::output::write_file(&p, &png)?;
        written.push(p);
    }
    Ok(written)
}
