//! `cobalt bench`: the thesis experiment, measured by [`raytrace::bench`].
//!
//! For each scene, each workload (Whitted: coherent rays; AO: diffuse rays), task size,
//! policy and mode (`regular`: equal costs; `cost`: estimates from a sample of each task's
//! paths), every camera is rendered by the render engine on the given devices, and one record
//! is kept per run. By default a quick run (about a minute on 2 cores) on `builtin:forest`; `--full` is
//! the thesis's matrix at 1024×1024 with four cameras. `--simulate` replays the measured tasks
//! on simulated machines; `--plots` draws the thesis's charts. Here are the arguments, the
//! progress bar, the report's text and JSON, and the charts (`plots.rs`).

mod plots;

use std::num::NonZeroUsize;
use std::path::PathBuf;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use raytrace::bench::{Machines, Record, SceneMatrix, SimRecord, TradePoint, table};
use raytrace::cost::SampleRate;
use raytrace::paths::Mode;
use raytrace::shade::Shader;
use raytrace::{BuildPreset, Bvh, Camera, Scene, SceneNeeds};
use sched::Policy;

use crate::args::{Devices, MAX_AO_SAMPLES, ShaderKind, Size, distinct, sample_rate, task_size};
use crate::error::CliError;

/// Arguments of `cobalt bench`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A scene (OBJ file or `builtin:NAME[:detail]`); repeat for several. Default
    /// `builtin:forest`.
    #[arg(long = "scene")]
    scenes: Vec<String>,
    /// The thesis's matrix: 1024x1024, four cameras (quick default: 512x512, one camera).
    #[arg(long)]
    full: bool,
    /// Image size `WxH` (overrides the default of quick or full).
    #[arg(long)]
    size: Option<Size>,
    /// Orbit cameras per run, 1..=4 (overrides the default of quick or full).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4))]
    cameras: Option<u32>,
    /// Devices, as for `cobalt render`.
    #[arg(long, default_value = "cpu:2")]
    devices: Devices,
    /// Task sizes in rays, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "16384,4096,512", value_parser = task_size)]
    task_sizes: Vec<NonZeroUsize>,
    /// Policies, comma-separated (default all five).
    #[arg(long, value_delimiter = ',')]
    policies: Option<Vec<Policy>>,
    /// Workloads, comma-separated: `whitted` (coherent rays), `ao` (diffuse rays).
    #[arg(long, value_enum, value_delimiter = ',', default_value = "whitted,ao")]
    shaders: Vec<ShaderKind>,
    /// Share of each task's paths sampled to estimate it (cost mode; default: 1/64 for
    /// `whitted`, 1/32 for `ao`).
    #[arg(long, value_parser = sample_rate)]
    sample_rate: Option<SampleRate>,
    /// How the estimate counts a sampled path, as for `cobalt render`: `trace`, `reduced` or
    /// `first-leaf`.
    #[arg(long, default_value = "trace")]
    walk: raytrace::Walk,
    /// Run every plan as planned: no device left idle runs backup copies of the tasks
    /// another device holds (the thesis's pure static behaviour).
    #[arg(long)]
    no_backups: bool,
    /// Slowed devices, as for `cobalt render`: `DEVICE=K[,…]`.
    #[arg(long, value_delimiter = ',', value_parser = crate::args::slow_by)]
    slow: Vec<raytrace::paths::SlowBy>,
    /// AO rays per primary hit, 1..=4096.
    #[arg(long, default_value_t = 32,
          value_parser = clap::value_parser!(u32).range(1..=MAX_AO_SAMPLES as i64))]
    ao_samples: u32,
    /// Runs of every cell, 1..=100, in rounds (each round runs the whole matrix once); the
    /// tables and `--json` give the medians and every run's MRays/s and balance.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
    repeats: u32,
    /// BVH build preset: fastest, very-fast, fast, medium, slow, very-slow, sah, or auto
    /// (sah, or medium for a scene whose largest 1% of triangles hold over half their area).
    #[arg(long, default_value = "auto")]
    preset: BuildPreset,
    /// Also replay the measured tasks on simulated machines of these device counts
    /// (comma-separated, each 1..=65536), of mixed speeds, behind PCIe-like (10 µs) and
    /// network-like (200 µs) launch latencies.
    #[arg(long, value_delimiter = ',',
          value_parser = clap::value_parser!(u32).range(1..=raytrace::bench::MAX_DEVICES as i64))]
    simulate: Vec<u32>,
    /// Also replay the measured tasks on machines of identical devices of the classes this
    /// run measured, one machine per entry of a device list: `cpu:N` is N devices at the
    /// measured CPU speed, `gpu:N` N at the measured GPU speed (e.g. `gpu:2,gpu:4,gpu:8`),
    /// each launch delayed by the class's measured launch overhead.
    #[arg(long)]
    project: Option<raytrace::bench::Projection>,
    /// Write every run (measured, then simulated and projected) as one JSON array to this
    /// file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Draw charts (PNG) into this directory: MRays/s, balance, sampling trade, cost image.
    #[arg(long)]
    plots: Option<PathBuf>,
    /// Leave out the sampling-rate table, which traces every ray of a frame on the host once
    /// per rate and task size: on a megapixel AO frame it takes longer than the matrix.
    #[arg(long)]
    no_trade: bool,
    /// Under `mpirun`: every rank is a node with the `--devices` of its own; compares the
    /// policies (default static-lpt, queue-fifo, queue-sorted, hybrid) over the nodes in cost mode,
    /// with balance over nodes and the time spent in MPI, then simulates 16 and 64 nodes
    /// behind the measured latency (feature `mpi`).
    #[cfg(feature = "mpi")]
    #[arg(long, conflicts_with_all = ["plots", "simulate", "project", "full", "repeats"])]
    mpi: bool,
    /// The path cells' calibration (as for `cobalt render`): every cell's first frame plans
    /// with the file as it was read, and what the cells learnt is written back at the end.
    #[command(flatten)]
    calibration: crate::calibration::CalibrationArgs,
}

/// The matrix the arguments ask for, with the defaults of a quick or a full run filled in.
struct Matrix {
    width: u32,
    height: u32,
    cameras: usize,
    task_sizes: Vec<NonZeroUsize>,
    policies: Vec<Policy>,
    modes: Vec<Mode>,
    workloads: Vec<Shader>,
    scenes: Vec<String>,
    /// What every scene must provide for the workloads.
    needs: SceneNeeds,
}

impl Matrix {
    fn of(args: &Args) -> Self {
        let Size { width, height } =
            args.size
                .unwrap_or(Size::square(if args.full { 1024 } else { 512 }));
        let shader = |s: &ShaderKind| s.shader(args.ao_samples, None);
        Self {
            width,
            height,
            cameras: args
                .cameras
                .map_or(if args.full { 4 } else { 1 }, |c| c as usize),
            task_sizes: args.task_sizes.clone(),
            policies: args
                .policies
                .clone()
                .unwrap_or_else(|| Policy::ALL.to_vec()),
            modes: Mode::ALL.to_vec(),
            scenes: if args.scenes.is_empty() {
                vec![String::from("builtin:forest")]
            } else {
                args.scenes.clone()
            },
            needs: if args.shaders.contains(&ShaderKind::Whitted) {
                SceneNeeds::WHITTED
            } else {
                SceneNeeds::AO
            },
            workloads: args.shaders.iter().map(shader).collect(),
        }
    }
}

/// What the scenes gave: the measured runs, the simulated ones, the sampling trade, and the
/// first scene's cost image where charts are drawn.
#[derive(Default)]
struct Measured {
    records: Vec<Record>,
    sims: Vec<SimRecord>,
    points: Vec<TradePoint>,
    cost_png: Option<Vec<u8>>,
}

/// Runs the benchmark; every argument is checked before anything is measured.
pub fn run(args: Args) -> Result<(), CliError> {
    let started = Instant::now();
    crate::args::check_slow(&args.slow, args.devices.known_count())?;
    let policies = args.policies.as_deref().unwrap_or_default();
    let name = ToString::to_string;
    distinct("policies", policies, name, name)?;
    let shader = |s: &ShaderKind| format!("{s:?}").to_lowercase();
    distinct("shaders", &args.shaders, shader, shader)?;
    let size = ToString::to_string;
    distinct("task-sizes", &args.task_sizes, size, size)?;
    distinct("simulate", &args.simulate, u32::to_string, u32::to_string)?;
    let m = Matrix::of(&args);
    let ao = args
        .shaders
        .contains(&ShaderKind::Ao)
        .then_some(("ao-samples", args.ao_samples));
    let size = Size {
        width: m.width,
        height: m.height,
    };
    crate::limits::frame(size, size.pixels(), ao)?;
    check_outputs(&args, &m)?;
    if let Some(p) = &args.project {
        let machine = ToString::to_string;
        distinct("project", &p.machines, machine, machine)?;
        p.check(args.devices.specs())?;
    }
    #[cfg(feature = "mpi")]
    if args.mpi {
        return run_mpi(&args, m, started);
    }
    let store = args.calibration.open()?.map(std::cell::RefCell::new);
    // Every scene is loaded before anything is measured, so a bad file fails the command at
    // once instead of after the first scene's runs.
    let loaded = m
        .scenes
        .iter()
        .map(|s| Ok(crate::limits::scene(s)?.load(m.needs)?))
        .collect::<Result<Vec<_>, CliError>>()?;
    let mut measured = Measured::default();
    for (name, scene) in m.scenes.iter().zip(&loaded) {
        measure_scene(&args, &m, (name, scene), store.as_ref(), &mut measured)?;
    }
    if let Some(store) = &store {
        let report = store.borrow().save();
        for r in measured.records.iter_mut() {
            if let Some(c) = &mut r.calibration {
                c.written_entries = report.written_entries;
            }
        }
    }
    let Measured {
        records,
        sims,
        points,
        cost_png,
    } = measured;
    let mut out = summary(&args, &m, &records, &sims, &points);
    if let Some(dir) = &args.plots {
        let files = plots::write_all(dir, &records, &points, cost_png)?;
        let names: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
        out += &format!("\nCharts: {}\n", names.join(", "));
    }
    out += &format!(
        "\n{} runs measured, {} simulated or projected, in {:.1} s.\n",
        records.len(),
        sims.len(),
        started.elapsed().as_secs_f64()
    );
    crate::print::print_text(&out)?;
    write_json(args.json.as_deref(), &records, &sims, &points)
}

/// Checks every output (`--json`, the charts of `--plots`, the calibration) now rather than
/// after the whole matrix has run: none may be an input (a scene, the calibration) or another
/// output.
fn check_outputs(args: &Args, m: &Matrix) -> Result<(), CliError> {
    let scenes: Vec<(&'static str, &std::path::Path)> = m
        .scenes
        .iter()
        .map(|s| ("scene", std::path::Path::new(s)))
        .collect();
    let mut inputs = scenes.clone();
    let calibration = args.calibration.check(&scenes)?;
    inputs.extend(calibration.as_deref().map(|c| ("calibration", c)));
    let charts: Vec<PathBuf> = match &args.plots {
        // A directory not there yet holds no input.
        Some(dir) if dir.is_dir() => plots::FILES.iter().map(|f| dir.join(f)).collect(),
        _ => Vec::new(),
    };
    let mut outputs = vec![("json", args.json.as_deref())];
    outputs.extend(charts.iter().map(|c| ("plots", Some(c.as_path()))));
    crate::output::Outputs::check(&outputs, &inputs)?;
    Ok(())
}

/// Writes every record (measured or over the ranks, simulated, then the sampling trade) as one
/// JSON array to `path`, if given.
fn write_json(
    path: Option<&std::path::Path>,
    records: &[Record],
    sims: &[SimRecord],
    points: &[TradePoint],
) -> Result<(), CliError> {
    let Some(path) = path else {
        return Ok(());
    };
    let json = |e: serde_json::Error| CliError::Write(e.to_string());
    let all = (records.iter().map(serde_json::to_value))
        .chain(sims.iter().map(serde_json::to_value))
        .chain(points.iter().map(serde_json::to_value))
        .collect::<Result<Vec<_>, _>>()
        .map_err(json)?;
    let text = serde_json::to_vec_pretty(&all).map_err(json)?;
    crate::output::write_file(path, &text)
}

/// The matrix of one scene as the arguments ask for it, on this process's devices.
fn scene_matrix<'a>(
    args: &'a Args,
    m: &'a Matrix,
    (name, scene, bvh): (&'a str, &'a Scene, &'a Bvh),
    store: Option<&'a std::cell::RefCell<raytrace::run::Store>>,
) -> SceneMatrix<'a> {
    SceneMatrix {
        scene_name: name,
        scene,
        bvh,
        devices: args.devices.specs(),
        device_list: args.devices.as_str(),
        workloads: &m.workloads,
        task_sizes: &m.task_sizes,
        policies: &m.policies,
        modes: &m.modes,
        cameras: m.cameras,
        width: m.width,
        height: m.height,
        ao_samples: args.ao_samples,
        sample_rate: args.sample_rate,
        walk: args.walk,
        backups: !args.no_backups,
        slow: &args.slow,
        repeats: args.repeats as usize,
        calibration: store,
        path_devices: Default::default(),
        #[cfg(feature = "mpi")]
        cluster: None,
    }
}

/// One scene's matrix, with a progress bar, then its simulated machines, its sampling trade
/// and (for the first scene with charts) its cost image, added to `out`.
fn measure_scene(
    args: &Args,
    m: &Matrix,
    (name, scene): (&String, &Scene),
    store: Option<&std::cell::RefCell<raytrace::run::Store>>,
    out: &mut Measured,
) -> Result<(), CliError> {
    let bvh = Bvh::build(scene, args.preset)?;
    let matrix = scene_matrix(args, m, (name, scene, &bvh), store);
    let bar = ProgressBar::new(matrix.runs() as u64);
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} {msg} ({elapsed})")
            .map_err(|e| CliError::Write(e.to_string()))?
            .progress_chars("=> "),
    );
    bar.set_prefix(name.clone());
    let (mut recs, replays) = matrix.run(|msg| {
        bar.set_message(msg.to_string());
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    let error_bar = table::replay_error(&recs).map(|(median, _, _)| median);
    let counts: Vec<usize> = args.simulate.iter().map(|&c| c as usize).collect();
    let machines = Machines::mixed(&counts);
    out.sims.extend(raytrace::bench::simulate(
        name, &replays, &machines, error_bar,
    )?);
    if let Some(p) = &args.project {
        let machines = Machines::projected(&p.machines, &m.policies);
        out.sims.extend(raytrace::bench::simulate(
            name, &replays, &machines, error_bar,
        )?);
    }
    if !args.no_trade {
        out.points.extend(raytrace::bench::sampling_trade(&matrix)?);
    }
    if args.plots.is_some() && out.cost_png.is_none() {
        out.cost_png = Some(cost_image(scene, &bvh, m.width, m.height)?);
    }
    out.records.append(&mut recs);
    Ok(())
}

/// The sample rate the heading names: the one given, else each workload's own.
fn rate_text(given: Option<SampleRate>, workloads: &[Shader]) -> String {
    match given {
        Some(rate) => rate.get().to_string(),
        None => workloads
            .iter()
            .map(|w| format!("{} ({})", w.sample_rate().get(), w.name()))
            .collect::<Vec<_>>()
            .join(", "),
    }
}

/// The report's text before the charts: its heading, then the tables.
fn summary(
    args: &Args,
    m: &Matrix,
    records: &[Record],
    sims: &[SimRecord],
    points: &[TradePoint],
) -> String {
    let mut out = format!(
        "cobalt bench: {} at {}x{}, {} camera(s), devices {}, sample rate {}{}\n\n",
        m.scenes.join(", "),
        m.width,
        m.height,
        m.cameras,
        args.devices.as_str(),
        rate_text(args.sample_rate, &m.workloads),
        if args.repeats > 1 {
            format!(
                ", {} runs of every cell (medians; MRays/s and balance show the runs' range)",
                args.repeats
            )
        } else {
            String::new()
        }
    );
    out += &table::runs(records);
    out += "\n";
    out += &table::replays(records);
    out += &table::predictions(records);
    out += "\nTargets on these devices:\n\n";
    out += &table::targets(records);
    if !args.no_trade {
        out += "\nSampling rate (thesis Table 4.1):\n\n";
        out += &table::trade(points);
    }
    let shown = m
        .task_sizes
        .iter()
        .map(|t| t.get())
        .find(|&t| t == 4096)
        .unwrap_or(m.task_sizes[0].get());
    if !args.simulate.is_empty() {
        let bar = table::replay_error(records).map_or(String::new(), |(median, _, _)| {
            format!(
                "; each figure within about ±{:.1} %, the median error of the simulator's replays of the measured runs",
                100.0 * median
            )
        });
        out += &format!(
            "\nSimulated machines from the measured tasks (PCIe link, task size {shown}; every link and size is in --json{bar}):\n\n"
        );
        out += &table::simulated(sims, shown);
    }
    if let Some(p) = &args.project {
        out += &format!(
            "\nProjected machines {} from the measured tasks (MRays/s / balance, thesis Figures 4.1 and 4.2; task size {shown}, every size is in --json):\n\n",
            p.list
        );
        out += &table::projected(sims, shown);
        out += "\n";
        out += &table::projection_assumptions(sims);
    }
    out
}

/// `cobalt bench --mpi` on every rank: every rank loads every scene (and all agree that it
/// did), then the ranks bench together and rank 0 prints the tables.
#[cfg(feature = "mpi")]
fn run_mpi(args: &Args, mut m: Matrix, started: Instant) -> Result<(), CliError> {
    use raytrace::bench::mpi;
    if args.policies.is_none() {
        m.policies = vec![
            Policy::StaticLpt,
            Policy::QueueFifo,
            Policy::QueueSorted,
            Policy::Hybrid,
        ];
    }
    // Cost mode, camera 0: the thesis's comparison of the policies between nodes.
    m.modes = vec![Mode::Cost];
    m.cameras = 1;
    let cluster = sched::mpi::Cluster::init()?;
    let loaded: Result<Vec<_>, CliError> = m
        .scenes
        .iter()
        .map(|name| {
            let scene = crate::limits::scene(name)?.load(m.needs)?;
            let bvh = Bvh::build(&scene, args.preset)?;
            Ok((scene, bvh))
        })
        .collect();
    let loaded = cluster.agree("loading the scenes", loaded)?;
    let matrices: Vec<SceneMatrix<'_>> = m
        .scenes
        .iter()
        .zip(&loaded)
        .map(|(name, (scene, bvh))| SceneMatrix {
            cluster: Some(&cluster),
            ..scene_matrix(args, &m, (name, scene, bvh), None)
        })
        .collect();
    let Some(bench) = mpi::bench(&cluster, &matrices)? else {
        return Ok(());
    };
    let text = format!(
        "cobalt bench --mpi: {} at {}x{}, camera 0, sample rate {}\n\n{}\n{} MPI runs and {} simulated in {:.1} s.\n",
        m.scenes.join(", "),
        m.width,
        m.height,
        rate_text(args.sample_rate, &m.workloads),
        bench.table(),
        bench.records.len(),
        bench.sims.len(),
        started.elapsed().as_secs_f64(),
    );
    crate::print::print_text(&text)?;
    write_json(args.json.as_deref(), &bench.records, &bench.sims, &[])
}

/// The cost image of thesis Figure 3.2 for camera 0: nodes `B` and triangle tests `T` of
/// every primary ray.
fn cost_image(scene: &Scene, bvh: &Bvh, width: u32, height: u32) -> Result<Vec<u8>, CliError> {
    let camera = Camera::orbit(&scene.bounds(), 0);
    let film = raytrace::cost_image::primary_cost_image(bvh, &camera, width, height);
    Ok(film.png(raytrace::film::ToneMap::Display)?)
}
