//! `mpirun -np N cobalt render …`: every rank renders the same image together
//! ([`raytrace::distributed`]); rank 0 writes the PNG, the report and the summary.
//!
//! Every fallible step before the render (loading the scene, building the BVH, opening this
//! node's devices) ends with an agreement between all ranks, so a failure on any rank ends
//! every rank with an error naming the ranks at fault, never a hang.

use std::path::Path;
use std::time::Instant;

use raytrace::devices::DeviceSpec;
use raytrace::distributed::{ClusterTracer, NodeGeneration};
use raytrace::film::ToneMap;
use raytrace::scheduled::{FailAfter, ScheduledTracer, Settings, build_devices};
use raytrace::shade::{RenderOptions, Shader, render as shade};
use raytrace::{BuildPreset, Bvh, SceneSource};
use sched::mpi::Cluster;
use serde::Serialize;

use crate::args::CameraChoice;
use crate::error::CliError;
use crate::output::Outputs;

/// A checked `cobalt render` command line, as every rank parsed it.
pub(crate) struct Job<'a> {
    pub scene: &'a str,
    pub shader: Shader,
    pub width: u32,
    pub height: u32,
    pub camera: CameraChoice,
    pub preset: BuildPreset,
    pub specs: &'a [DeviceSpec],
    pub faults: &'a [FailAfter],
    pub settings: Settings,
    pub out: &'a Path,
    pub report: Option<&'a Path>,
    pub json: bool,
    /// `--host-fallback`: a generation whose every node failed is traced on rank 0's host.
    pub host_fallback: bool,
}

/// The report of a render over ranks (rank 0's view).
#[derive(Debug, Serialize)]
struct Report {
    scene: String,
    shader: &'static str,
    width: u32,
    height: u32,
    ranks: usize,
    /// Devices of each rank, as given to `--devices`.
    devices_per_rank: String,
    policy: sched::Policy,
    mode: &'static str,
    task_size: usize,
    total_rays: usize,
    render_seconds: f64,
    mrays_per_s: f64,
    /// Σ busy / Σ (makespan × nodes) over the generations, nodes as the devices.
    balance_efficiency: f64,
    /// Seconds rank 0 spent inside MPI calls, and their share of the render.
    comm_seconds: f64,
    comm_share: f64,
    /// Per other rank: batches sent and seconds of their round trips not spent working.
    links: Vec<LinkReport>,
    generations: Vec<GenerationReport>,
}

#[derive(Debug, Serialize)]
struct LinkReport {
    rank: usize,
    batches: u64,
    round_trip_seconds: f64,
    overhead_seconds: f64,
}

#[derive(Debug, Serialize)]
struct GenerationReport {
    kind: &'static str,
    rays: usize,
    tasks: usize,
    estimate_seconds: f64,
    run_seconds: f64,
    broadcast_seconds: f64,
    makespan: f64,
    balance_efficiency: f64,
    ranks: Vec<usize>,
    speeds: Vec<f64>,
    busy: Vec<f64>,
    launches: Vec<u64>,
    tasks_per_rank: Vec<usize>,
    failures: Vec<String>,
    host_fallback: bool,
}

/// What every rank has agreed on before it renders: the job, rank 0's checked outputs
/// (`None` elsewhere), and the scene with its BVH.
struct Start {
    cluster: Cluster,
    outputs: Option<Outputs>,
    scene: raytrace::Scene,
    bvh: Bvh,
}

/// Joins the MPI job, checks rank 0's outputs (rank 0 writes every one, so before any rank
/// starts work) and loads the scene on every rank, each step agreed by all.
fn start(job: &Job<'_>) -> Result<Start, CliError> {
    let cluster = Cluster::init()?;
    let outputs = cluster.is_root().then(|| {
        Outputs::check(
            &[("out", Some(job.out)), ("report", job.report)],
            &[("scene", Path::new(job.scene))],
        )
    });
    let outputs = cluster.agree("checking the outputs", outputs.transpose())?;
    let loaded = SceneSource::parse(job.scene)
        .and_then(|s| s.load(job.shader.needs()))
        .and_then(|scene| Bvh::build(&scene, job.preset).map(|bvh| (scene, bvh)));
    let (scene, bvh) = cluster.agree("loading the scene", loaded)?;
    Ok(Start {
        cluster,
        outputs,
        scene,
        bvh,
    })
}

/// Renders `job` on every rank of the MPI job this process belongs to.
pub(crate) fn render(job: Job<'_>) -> Result<(), CliError> {
    let Start {
        cluster,
        outputs,
        scene,
        bvh,
    } = start(&job)?;
    let devices = build_devices(&bvh, job.specs, job.faults)
        .map_err(CliError::from)
        .and_then(|d| Ok(ScheduledTracer::new(&bvh, d, job.settings)?));
    let local = cluster.agree("opening this rank's devices", devices)?;

    let (camera, _) = job.camera.resolve(&scene.bounds());
    let options = RenderOptions::new(job.width, job.height, camera, job.shader);
    let mut tracer = ClusterTracer::new(&cluster, &bvh, local);
    let comm_before = cluster.comm_seconds();
    let started = Instant::now();
    let rendering = shade(&scene, &mut tracer, &options);
    let seconds = started.elapsed().as_secs_f64();
    let Some(outputs) = outputs else {
        return Ok(());
    };
    let fallbacks = tracer.stats().iter().filter(|g| g.host_fallback).count();
    if fallbacks > 0 && !job.host_fallback {
        let failures: Vec<_> = tracer
            .stats()
            .iter()
            .flat_map(|g| g.failures.iter().cloned())
            .collect();
        return Err(CliError::devices_failed(&device_list(job.specs), &failures));
    }

    let comm_seconds = cluster.comm_seconds() - comm_before;
    let report = Report {
        scene: job.scene.to_string(),
        shader: job.shader.name(),
        width: job.width,
        height: job.height,
        ranks: cluster.size(),
        devices_per_rank: device_list(job.specs),
        policy: job.settings.policy,
        mode: job.settings.mode.name(),
        task_size: job.settings.task_size.get(),
        total_rays: rendering.total_rays(),
        render_seconds: seconds,
        mrays_per_s: rendering.total_rays() as f64 / seconds.max(1e-12) / 1e6,
        balance_efficiency: node_balance(tracer.stats()),
        comm_seconds,
        comm_share: comm_seconds / seconds.max(1e-12),
        links: cluster
            .links()
            .iter()
            .enumerate()
            .skip(1)
            .map(|(rank, l)| LinkReport {
                rank,
                batches: l.batches,
                round_trip_seconds: l.round_trip_seconds,
                overhead_seconds: l.overhead_seconds(),
            })
            .collect(),
        generations: tracer.stats().iter().map(generation_report).collect(),
    };
    let image = rendering.film.png(ToneMap::Srgb)?;
    let report_json =
        serde_json::to_string_pretty(&report).map_err(|e| CliError::Write(e.to_string()))?;
    let report_json = format!("{report_json}\n");
    outputs.commit(&[("out", &image), ("report", report_json.as_bytes())])?;
    if job.json {
        outputs.print_json(&report)
    } else {
        outputs.print(&summary(&report))
    }
}

/// Balance efficiency over the nodes of every generation, long generations weighing more.
pub(crate) fn node_balance(gens: &[NodeGeneration]) -> f64 {
    let busy: f64 = gens
        .iter()
        .flat_map(|g| g.nodes.iter().map(|n| n.busy))
        .sum();
    let capacity: f64 = gens.iter().map(|g| g.makespan * g.nodes.len() as f64).sum();
    if capacity > 0.0 { busy / capacity } else { 1.0 }
}

fn generation_report(g: &NodeGeneration) -> GenerationReport {
    GenerationReport {
        kind: g.kind.name(),
        rays: g.rays,
        tasks: g.tasks,
        estimate_seconds: g.estimate_seconds,
        run_seconds: g.run_seconds,
        broadcast_seconds: g.broadcast_seconds,
        makespan: g.makespan,
        balance_efficiency: g.balance_efficiency,
        ranks: g.nodes.iter().map(|n| n.rank).collect(),
        speeds: g.nodes.iter().map(|n| n.speed).collect(),
        busy: g.nodes.iter().map(|n| n.busy).collect(),
        launches: g.nodes.iter().map(|n| n.launches).collect(),
        tasks_per_rank: g.nodes.iter().map(|n| n.tasks).collect(),
        failures: g.failures.iter().map(ToString::to_string).collect(),
        host_fallback: g.host_fallback,
    }
}

fn device_list(specs: &[DeviceSpec]) -> String {
    let items: Vec<String> = specs
        .iter()
        .map(|s| match s {
            DeviceSpec::Cpu { count, threads } => format!("cpu:{count}/{threads}"),
            DeviceSpec::Gpu(g) => format!("gpu:{g:?}"),
        })
        .collect();
    items.join(",")
}

fn summary(r: &Report) -> String {
    let mut s = format!(
        "{} {}x{} of {} on {} rank(s) × {}, {} {}, tasks of {}: {} rays in {:.3} s, {:.2} MRays/s, balance over nodes {:.1} %, MPI {:.3} s ({:.1} %)\n",
        r.shader,
        r.width,
        r.height,
        r.scene,
        r.ranks,
        r.devices_per_rank,
        r.policy,
        r.mode,
        r.task_size,
        r.total_rays,
        r.render_seconds,
        r.mrays_per_s,
        100.0 * r.balance_efficiency,
        r.comm_seconds,
        100.0 * r.comm_share,
    );
    for g in &r.generations {
        let speeds: Vec<String> = g.speeds.iter().map(|v| format!("{v:.3}")).collect();
        s += &format!(
            "  {:<10} {:>9} rays  {:>6} tasks  balance {:5.1} %  tasks per rank {:?}  speeds [{}]\n",
            g.kind,
            g.rays,
            g.tasks,
            100.0 * g.balance_efficiency,
            g.tasks_per_rank,
            speeds.join(", "),
        );
        if g.host_fallback {
            s += "    every node failed: traced on rank 0's host instead (--host-fallback)\n";
        }
        for f in &g.failures {
            s += &format!("    {f}\n");
        }
    }
    for l in &r.links {
        s += &format!(
            "  rank {}: {} batches, round trips {:.4} s, of which communication {:.4} s\n",
            l.rank, l.batches, l.round_trip_seconds, l.overhead_seconds
        );
    }
    s
}

/// The report of a path render over ranks (rank 0's view).
#[derive(Debug, Serialize)]
struct PathsReport {
    scene: String,
    shader: &'static str,
    width: u32,
    height: u32,
    ranks: usize,
    /// Devices of each rank, as given to `--devices`.
    devices_per_rank: String,
    pipeline: &'static str,
    policy: sched::Policy,
    mode: &'static str,
    task_size: usize,
    #[serde(flatten)]
    run: crate::path_run::PathRun,
}

/// Renders `job` by paths on every rank of the MPI job: on rank 0, every other rank is one
/// path device beside rank 0's own devices; the others render the tasks they are sent on
/// their own devices and return the paths' values.
pub(crate) fn render_paths(job: Job<'_>) -> Result<(), CliError> {
    use raytrace::distributed::render_over_ranks;
    use raytrace::paths::{PathRenderer, build_path_devices};

    let Start {
        cluster,
        outputs,
        scene,
        bvh,
    } = start(&job)?;
    let local = build_path_devices(&scene, &bvh, job.specs, job.faults);
    let devices = cluster.agree("opening this rank's devices", local)?;
    let (camera, _) = job.camera.resolve(&scene.bounds());
    let options = RenderOptions::new(job.width, job.height, camera, job.shader);
    let rendered = render_over_ranks(&cluster, devices, job.settings, &scene, &bvh, &options);
    let Some(outputs) = outputs else {
        // Another rank: it rendered what rank 0 sent until the frame was done.
        return rendered.map(drop).map_err(Into::into);
    };
    let mut lost = Vec::new();
    let frame = match rendered {
        Ok(Some(frame)) => frame,
        // Only the other ranks get no frame, and they have no outputs.
        Ok(None) => return Ok(()),
        Err(sched::SchedError::AllDevicesFailed { failures, .. }) => {
            if !job.host_fallback {
                return Err(CliError::devices_failed(&device_list(job.specs), &failures));
            }
            lost = failures;
            let threads = std::thread::available_parallelism().map_or(1, usize::from);
            let spec = [DeviceSpec::Cpu { count: 1, threads }];
            let host = build_path_devices(&scene, &bvh, &spec, &[])?;
            PathRenderer::new(host, job.settings)?.render(&scene, &bvh, &options)?
        }
        Err(e) => return Err(e.into()),
    };
    let mut run = crate::path_run::PathRun::new(1, frame.stats.seconds, &frame.stats);
    run.host_fallback = !lost.is_empty();
    run.failures.extend(lost.iter().map(ToString::to_string));
    let image = frame.film.png(ToneMap::Srgb)?;
    let report = PathsReport {
        scene: job.scene.to_string(),
        shader: job.shader.name(),
        width: job.width,
        height: job.height,
        ranks: cluster.size(),
        devices_per_rank: device_list(job.specs),
        pipeline: "paths",
        policy: job.settings.policy,
        mode: job.settings.mode.name(),
        task_size: job.settings.task_size.get(),
        run,
    };
    let json = serde_json::to_string_pretty(&report).map_err(|e| CliError::Write(e.to_string()))?;
    let json = format!("{json}\n");
    outputs.commit(&[("out", &image), ("report", json.as_bytes())])?;
    if job.json {
        return outputs.print_json(&report);
    }
    let r = &report.run;
    let text = format!(
        "{} {}x{} of {} by paths on {} rank(s) × {}, {} {}, tasks of {}: {}\n{}",
        report.shader,
        report.width,
        report.height,
        report.scene,
        report.ranks,
        report.devices_per_rank,
        report.policy,
        report.mode,
        report.task_size,
        r.figures(),
        r.notes(),
    );
    outputs.print(&text)
}
