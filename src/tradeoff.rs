//! `cobalt tradeoff`: what speed costs in accuracy, measured on one scene in one run by
//! [`raytrace::tradeoff`].
//!
//! Two tables:
//! - BVH build preset: build time and SAH cost against trace throughput (primary rays of the
//!   four orbit cameras, closest hit; AO probes, any hit), all on the same rays;
//! - AO sample count: image error against a high-sample reference (its own Halton
//!   scrambling seed, so the reference's noise is independent of the estimate's) against render
//!   time.

use std::path::Path;

use raytrace::BuildPreset;
use raytrace::tradeoff::{PresetRecord, SampleRecord};
use serde::Serialize;

use crate::args::{MAX_AO_SAMPLES, Size, camera_index};
use crate::error::CliError;

/// Arguments of `cobalt tradeoff`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// An OBJ file, or `builtin:forest|hairball|cornell[:detail]`.
    #[arg(long, default_value = "builtin:forest")]
    scene: String,
    /// Image size for both tables, `WIDTHxHEIGHT`.
    #[arg(long, default_value = "128x128")]
    size: Size,
    /// Orbit camera of the AO images, 0..3.
    #[arg(long, default_value = "0", value_parser = camera_index)]
    camera: usize,
    /// Presets to compare, comma-separated: fastest, very-fast, fast, medium, slow, very-slow,
    /// sah (default all seven).
    #[arg(long, value_delimiter = ',', value_parser = preset)]
    presets: Option<Vec<BuildPreset>>,
    /// AO sample counts to compare with the reference, comma-separated, each 1..=4096.
    #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32,64,128",
          value_parser = ao_sample_count)]
    ao_samples: Vec<u32>,
    /// Samples of the reference image, 1..=4096.
    #[arg(long, default_value_t = 1024, value_parser = ao_sample_count)]
    reference: u32,
    /// Also write the records as JSON to this file.
    #[arg(long)]
    json: Option<std::path::PathBuf>,
}

#[derive(Debug, Serialize)]
struct Report {
    scene: String,
    width: u32,
    height: u32,
    threads: usize,
    presets: Vec<PresetRecord>,
    reference_samples: u32,
    reference_seconds: f64,
    ao: Vec<SampleRecord>,
}

/// One BVH preset of `--presets`.
fn preset(text: &str) -> Result<BuildPreset, String> {
    text.trim().parse()
}

/// One AO sample count, `1..=MAX_AO_SAMPLES`.
fn ao_sample_count(text: &str) -> Result<u32, String> {
    match text.trim().parse::<u32>() {
        Ok(n) if (1..=MAX_AO_SAMPLES).contains(&n) => Ok(n),
        _ => Err(format!("expected a sample count in 1..={MAX_AO_SAMPLES}")),
    }
}

/// Runs both measurements and prints the tables.
pub fn run(args: Args) -> Result<(), CliError> {
    let Size { width, height } = args.size;
    let camera = args.camera;
    let presets = args
        .presets
        .clone()
        .unwrap_or_else(|| BuildPreset::ALL.to_vec());
    let counts = &args.ao_samples;
    let most = counts.iter().map(|&n| ("ao-samples", n));
    let most = most
        .chain([("reference", args.reference)])
        .max_by_key(|&(_, n)| n);
    crate::limits::frame(args.size, args.size.pixels(), most)?;
    let name = |p: &BuildPreset| p.name().to_string();
    crate::args::distinct("presets", &presets, name, name)?;
    crate::args::distinct("ao-samples", counts, u32::to_string, u32::to_string)?;
    let outputs = crate::output::Outputs::check(
        &[("json", args.json.as_deref())],
        &[("scene", Path::new(&args.scene))],
    )?;
    let scene = crate::limits::scene(&args.scene)?.load(raytrace::SceneNeeds::AO)?;

    let size = (width, height);
    let preset_records = raytrace::tradeoff::presets(&scene, size, camera, &presets)?;
    let (reference_seconds, ao_records) =
        raytrace::tradeoff::ao_samples(&scene, size, camera, counts, args.reference)?;

    let report = Report {
        scene: args.scene.clone(),
        width,
        height,
        threads: rayon::current_num_threads(),
        presets: preset_records,
        reference_samples: args.reference,
        reference_seconds,
        ao: ao_records,
    };
    let text = serde_json::to_vec_pretty(&report).map_err(|e| CliError::Write(e.to_string()))?;
    outputs.commit(&[("json", &text)])?;
    outputs.print(&tables(&report))
}

fn tables(r: &Report) -> String {
    let mut s = format!(
        "{} at {}x{}, {} threads\n\nBVH preset: build time vs trace speed (primary: 4 orbit cameras, closest hit; AO: 32 rays per hit, any hit)\n\n| preset | build s | SAH | nodes | primary MRays/s | AO MRays/s |\n|---|---:|---:|---:|---:|---:|\n",
        r.scene, r.width, r.height, r.threads
    );
    for p in &r.presets {
        s += &format!(
            "| {} | {:.3} | {:.1} | {} | {:.2} | {:.2} |\n",
            p.preset, p.build_seconds, p.sah_cost, p.nodes, p.primary_mrays_per_s, p.ao_mrays_per_s
        );
    }
    s += &format!(
        "\nAO samples: error against a {}-sample reference ({:.2} s) vs render time\n\n| samples | rays | seconds | speed-up | RMSE | max error |\n|---:|---:|---:|---:|---:|---:|\n",
        r.reference_samples, r.reference_seconds
    );
    for a in &r.ao {
        s += &format!(
            "| {} | {} | {:.3} | {:.1}x | {:.4} | {:.3} |\n",
            a.samples, a.rays, a.seconds, a.speedup, a.rmse, a.max_error
        );
    }
    s
}
