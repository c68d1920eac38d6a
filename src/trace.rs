//! `cobalt trace`: binary rays in, binary hits out, JSON timing: the contract any external
//! tool can check our hits and speed against (see README.md, "cobalt trace").

use std::path::{Path, PathBuf};
use std::time::Instant;

use raytrace::{Bvh, HitBatch, Layout, RAY_RECORD_BYTES, RayBatch, SceneNeeds, traverse};
use serde::Serialize;

use crate::error::CliError;

/// Which device traces.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Device {
    /// All CPU cores (rayon).
    Cpu,
    /// The first usable GPU adapter (wgpu; software adapters only with
    /// `COBALT_GPU_SOFTWARE=1`).
    Gpu,
}

/// Arguments of `cobalt trace`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    scene: crate::args::SceneArgs,
    /// Rays: little-endian `f32 × 8` per ray (`ox oy oz dx dy dz tmin tmax`).
    #[arg(long)]
    rays: PathBuf,
    /// Hits: 8 bytes per ray, `f32 t` (+inf on a miss) and `u32 prim` (0xFFFFFFFF on a miss).
    #[arg(long)]
    out: PathBuf,
    /// Stop at any hit (shadow-ray semantics); `t` is then the distance of the hit found.
    #[arg(long)]
    any_hit: bool,
    /// The device that traces.
    #[arg(long, value_enum, default_value = "cpu")]
    device: Device,
    /// The tree walked: `wide` (the default: 8-wide on the CPU, the compressed 8-wide nodes on
    /// the GPU) or `binary`. Both give the same closest hits.
    #[arg(long, default_value = "wide")]
    layout: Layout,
    /// Trace the rays this many times and report the fastest (the first pays for starting
    /// the threads and warming the caches).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    repeats: u32,
    /// Print one JSON object with the timings.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Serialize)]
struct Report {
    scene: String,
    triangles: usize,
    preset: String,
    device: &'static str,
    /// The GPU adapter's name with `--device gpu`.
    #[serde(skip_serializing_if = "Option::is_none")]
    adapter: Option<String>,
    any_hit: bool,
    /// The tree walked (`wide` or `binary`).
    layout: &'static str,
    /// With `--device gpu`: nodes the reduced walk fetches per ray on `layout`'s tree.
    #[serde(skip_serializing_if = "Option::is_none")]
    nodes_per_ray: Option<f64>,
    /// With `--device gpu`: `nodes_per_ray` times the bytes one node fetch reads.
    #[serde(skip_serializing_if = "Option::is_none")]
    node_bytes_per_ray: Option<f64>,
    rays: usize,
    hits: usize,
    /// Traversal only.
    seconds: f64,
    mrays_per_s: f64,
    build_seconds: f64,
    /// The whole BVH build: obvhs's, flattening and collapsing into the wide tree.
    total_build_seconds: f64,
    sah_cost: f64,
    load_seconds: f64,
    threads: usize,
}

/// Runs the command: every input is read and checked before anything is written.
pub fn run(args: Args) -> Result<(), CliError> {
    let (preset, layout) = (args.scene.preset, args.layout);
    if args.scene.scene == "-" && args.rays == Path::new("-") {
        return Err(CliError::Arg {
            flag: "rays",
            value: "-".into(),
            message: "--scene already reads standard input".into(),
        });
    }
    let outputs = crate::output::Outputs::check(
        &[("out", Some(&args.out))],
        &[
            ("scene", Path::new(&args.scene.scene)),
            ("rays", &args.rays),
        ],
    )?;
    let loading = Instant::now();
    let scene = crate::limits::scene(&args.scene.scene)?.load(SceneNeeds::AO)?;
    let load_seconds = loading.elapsed().as_secs_f64();
    let mut rays = read_rays(&args.rays)?;
    scene.rays_to_scene(&mut rays);
    let bvh = Bvh::build(&scene, preset)?;

    let (hits, seconds, adapter, nodes) = match args.device {
        Device::Cpu => {
            let mut best = f64::INFINITY;
            // One batch for every repeat, as a renderer keeps one from frame to frame.
            let mut hits = HitBatch::default();
            for _ in 0..args.repeats {
                let tracing = Instant::now();
                traverse::hits_into(&bvh, &rays, args.any_hit, layout, &mut hits);
                best = best.min(tracing.elapsed().as_secs_f64());
            }
            (hits, best, None, None)
        }
        Device::Gpu => gpu_trace(&bvh, &rays, args.any_hit, layout)?,
    };
    outputs.commit(&[("out", &hits.to_records())])?;

    let report = Report {
        scene: args.scene.scene.clone(),
        triangles: scene.len(),
        preset: bvh.report().preset.name().to_string(),
        device: match args.device {
            Device::Cpu => "cpu",
            Device::Gpu => "gpu",
        },
        adapter,
        any_hit: args.any_hit,
        layout: layout.name(),
        nodes_per_ray: nodes.map(|(n, _)| n),
        node_bytes_per_ray: nodes.map(|(n, bytes)| n * bytes),
        rays: rays.len(),
        hits: hits.prim.iter().filter(|&&p| p != u32::MAX).count(),
        seconds,
        mrays_per_s: rays.len() as f64 / seconds.max(1e-12) / 1e6,
        build_seconds: bvh.report().build_seconds,
        total_build_seconds: bvh.report().total_seconds,
        sah_cost: bvh.report().sah_cost,
        load_seconds,
        threads: rayon::current_num_threads(),
    };
    if args.json {
        outputs.print_json(&report)
    } else {
        outputs.print(&format!(
            "{} rays ({} hit) on {} ({} triangles): {:.3} s, {:.2} MRays/s; BVH {} built in {:.3} s\n",
            report.rays,
            report.hits,
            report.scene,
            report.triangles,
            report.seconds,
            report.mrays_per_s,
            report.preset,
            report.build_seconds
        ))
    }
}

/// Traces on the first usable GPU adapter: hits, seconds (upload, kernels and read-back of
/// the rays; the BVH upload and kernel compilation excluded), the adapter's name, and the
/// nodes the reduced walk fetches per ray on `layout`'s tree with the bytes of one fetch.
#[cfg(feature = "gpu")]
fn gpu_trace(
    bvh: &Bvh,
    rays: &RayBatch,
    any_hit: bool,
    layout: Layout,
) -> Result<GpuTrace, CliError> {
    use raytrace::cost::CountRays;
    use raytrace::devices::GpuSelect;
    use raytrace::gpu::{GpuContext, GpuDevice, GpuOptions};
    // The first GPU found, with the `COBALT_GPU_*` options from the environment.
    let ctx = GpuContext::open(GpuSelect::All, GpuOptions::from_env())
        .map_err(CliError::gpu)?
        .swap_remove(0);
    let name = ctx.info.name.clone();
    let dev = GpuDevice::with_layout(ctx, bvh, layout).map_err(CliError::gpu)?;
    let tracing = Instant::now();
    let hits = dev
        .hits(any_hit, rays, &[&(0..rays.len())])
        .map_err(CliError::gpu)?;
    let seconds = tracing.elapsed().as_secs_f64();
    let index: Vec<usize> = (0..rays.len()).collect();
    let (_, counts) = dev
        .count_at(rays, raytrace::Walk::Reduced, &index)
        .map_err(CliError::gpu)?;
    let nodes: u64 = counts.iter().map(|c| u64::from(c.nodes)).sum();
    let per_ray = nodes as f64 / rays.len().max(1) as f64;
    Ok((
        hits,
        seconds,
        Some(name),
        Some((per_ray, dev.node_bytes() as f64)),
    ))
}

/// Hits, seconds, the adapter's name, and nodes per ray with the bytes of a node fetch.
type GpuTrace = (HitBatch, f64, Option<String>, Option<(f64, f64)>);

/// Without the `gpu` feature, `--device gpu` is refused.
#[cfg(not(feature = "gpu"))]
fn gpu_trace(_: &Bvh, _: &RayBatch, _: bool, _: Layout) -> Result<GpuTrace, CliError> {
    Err(CliError::gpu(crate::error::NO_GPU))
}

/// Reads and checks a ray file (or standard input for `-`) one ray at a time, so that the
/// first bad ray ends the read; the error names the file, the ray and the bad value.
pub(crate) fn read_rays(path: &Path) -> Result<RayBatch, CliError> {
    let read_err = |source| CliError::Read {
        path: path.to_owned(),
        source,
    };
    let bad = |ray: usize, message: String| CliError::Record {
        path: path.to_owned(),
        what: "ray",
        index: ray,
        message,
    };
    let max_rays = (crate::input::MAX_INPUT_BYTES / RAY_RECORD_BYTES as u64) as usize;
    // A regular file says how many rays to expect; anything else grows as it is read.
    let expected = std::fs::metadata(path)
        .ok()
        .filter(|m| m.is_file() && path != Path::new("-"))
        .map_or(0, |m| {
            (m.len() / RAY_RECORD_BYTES as u64).min(max_rays as u64) as usize
        });
    let mut input = crate::input::open(path)?;
    let mut rays = RayBatch::with_capacity(expected);
    let mut record = [0u8; RAY_RECORD_BYTES];
    for i in 0.. {
        let got = fill(&mut input, &mut record).map_err(read_err)?;
        if got == 0 {
            break;
        }
        if got < RAY_RECORD_BYTES {
            let len = i * RAY_RECORD_BYTES + got;
            return Err(bad(
                i,
                format!(
                    "truncated: the file has {len} bytes, not a multiple of {RAY_RECORD_BYTES}"
                ),
            ));
        }
        if i == max_rays {
            return Err(crate::input::too_large(path));
        }
        rays.push_record(&record)
            .map_err(|message| bad(i, message))?;
    }
    Ok(rays)
}

/// Reads until `buf` is full or the input ends; returns the bytes read.
fn fill(input: &mut impl std::io::Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match input.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(got)
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    proptest! {
        /// Random bytes: rays that are all usable, or an error naming the file.
        #[test]
        fn random_ray_files_never_panic(body in proptest::collection::vec(any::<u8>(), 0..200)) {
            let p = std::env::temp_dir()
                .join(format!("cobalt-rays-{}-prop", std::process::id()));
            std::fs::write(&p, &body).expect("temp file");
            match read_rays(&p) {
                Ok(rays) => {
                    prop_assert_eq!(rays.len(), body.len() / RAY_RECORD_BYTES);
                    for i in 0..rays.len() {
                        prop_assert!(rays.tmin[i] >= 0.0 && rays.tmin[i] <= rays.tmax[i]);
                    }
                }
                Err(e) => prop_assert!(e.to_string().contains("cobalt-rays")),
            }
        }
    }
}
