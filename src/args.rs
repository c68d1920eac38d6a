//! The arguments several commands share, each defined once: typed values that clap parses
//! (so a bad value is clap's error, naming the flag and the value), and groups of flags that a
//! command takes whole with `#[command(flatten)]`.
//!
//! A value's limits are checked here, before any work; what depends on several flags at once
//! (a `--fail` device index against the `--devices` list) is checked by the command.

use std::fmt;
use std::num::NonZeroUsize;
use std::path::PathBuf;
use std::str::FromStr;

use raytrace::Walk;
use raytrace::cost::SampleRate;
use raytrace::devices::{DeviceSpec, GpuSelect};
use raytrace::glam::Vec3;
use raytrace::paths::{FailAfter, Mode, Settings, SlowBy};
use raytrace::{BuildPreset, Camera};
use sched::{Fault, Policy};

use crate::error::CliError;

/// Largest image side: keeps a typo like `--size 1024000x1` from allocating gigabytes.
pub const MAX_SIDE: u32 = 16384;

/// Most devices, and most threads per device: a typo should not start a million threads.
const MAX_DEVICES: usize = 1024;

/// Largest task: a generation of a 16384² image with 32 AO probes fits `u32` task indices
/// at any size above this, and no sensible task is larger.
const MAX_TASK_SIZE: usize = 1 << 24;

/// Most AO rays per primary hit.
pub const MAX_AO_SAMPLES: u32 = 4096;

/// An image size, `WIDTHxHEIGHT`, each side in `1..=MAX_SIDE`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Size {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
}

impl Size {
    /// A square image.
    pub const fn square(side: u32) -> Self {
        Self {
            width: side,
            height: side,
        }
    }

    /// Pixels in all.
    pub fn pixels(self) -> usize {
        self.width as usize * self.height as usize
    }
}

impl FromStr for Size {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        let (w, h) = text
            .split_once(['x', 'X'])
            .ok_or("expected WIDTHxHEIGHT, e.g. 1024x1024")?;
        let side = |s: &str| match s.trim().parse::<u32>() {
            Ok(n) if (1..=MAX_SIDE).contains(&n) => Ok(n),
            _ => Err(format!("{s:?} is not a side length in 1..={MAX_SIDE}")),
        };
        Ok(Self {
            width: side(w)?,
            height: side(h)?,
        })
    }
}

impl fmt::Display for Size {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

/// One of the four orbit cameras, `0..=3`.
pub fn camera_index(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(i) if i < 4 => Ok(i),
        _ => Err("expected one of the orbit cameras 0, 1, 2 or 3 (or --eye and --at)".into()),
    }
}

/// A point `X,Y,Z`, every coordinate finite.
pub fn point(text: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = text
        .split(',')
        .map(|c| c.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| "expected three finite numbers X,Y,Z")?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err("expected three finite numbers X,Y,Z".into()),
    }
}

/// Rays (or paths) per task, in `1..=MAX_TASK_SIZE`.
pub fn task_size(text: &str) -> Result<NonZeroUsize, String> {
    match text.trim().parse::<usize>() {
        Ok(n) if n <= MAX_TASK_SIZE => NonZeroUsize::new(n),
        _ => None,
    }
    .ok_or_else(|| format!("expected a whole number of rays in 1..={MAX_TASK_SIZE}"))
}

/// The share of a task's rays an estimate traces, in `(0, 1]`.
pub fn sample_rate(text: &str) -> Result<SampleRate, String> {
    match text.trim().parse::<f64>().map(SampleRate::new) {
        Ok(Ok(rate)) => Ok(rate),
        _ => Err("expected a fraction in (0, 1], e.g. 0.125".into()),
    }
}

/// `--sample-error`: how far a CPU estimate's sample refines (see
/// `ReducedTraversal::with_sample_error`): the disagreement of its two halves it stops at, or
/// `off` for the whole sample at `--sample-rate`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleError(pub Option<f64>);

impl std::str::FromStr for SampleError {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        let text = text.trim();
        if text == "off" {
            return Ok(Self(None));
        }
        match text.parse::<f64>() {
            Ok(e) if e > 0.0 && e < 1.0 => Ok(Self(Some(e))),
            _ => Err(format!(
                "sample error `{text}` is neither `off` nor a fraction in (0, 1), e.g. 0.08"
            )),
        }
    }
}

impl std::fmt::Display for SampleError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            Some(e) => e.fmt(f),
            None => f.write_str("off"),
        }
    }
}

/// A length: finite and above zero.
pub fn positive_length(text: &str) -> Result<f32, String> {
    match text.trim().parse::<f32>() {
        Ok(d) if d.is_finite() && d > 0.0 => Ok(d),
        _ => Err("expected a finite number > 0".into()),
    }
}

/// A `--devices` list as typed, and the devices it names: the list of
/// [`raytrace::devices::parse_devices`], plus `cpu` alone for one device with every core.
/// GPU entries (`gpu:all`, `gpu:K`) open wgpu adapters when the devices are built.
#[derive(Debug, Clone)]
pub struct Devices {
    text: String,
    specs: Vec<DeviceSpec>,
}

impl Devices {
    /// The list as the user typed it, for reports and errors.
    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// Every entry, in order.
    pub fn specs(&self) -> &[DeviceSpec] {
        &self.specs
    }

    /// CPU devices in all.
    pub fn cpu_devices(&self) -> usize {
        self.cpu().map(|(count, _)| count).sum()
    }

    /// Whether a GPU entry is listed: how many devices it opens is known only once they are.
    pub fn has_gpu(&self) -> bool {
        self.specs.iter().any(|s| matches!(s, DeviceSpec::Gpu(_)))
    }

    /// How many devices the list makes, where known before they are opened (`usize::MAX`
    /// with GPU entries): the bound of a `--fail` or `--slow` device index.
    pub fn known_count(&self) -> usize {
        if self.has_gpu() {
            usize::MAX
        } else {
            self.cpu_devices()
        }
    }

    fn cpu(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.specs.iter().filter_map(|s| match *s {
            DeviceSpec::Cpu { count, threads } => Some((count, threads)),
            DeviceSpec::Gpu(_) => None,
        })
    }
}

impl FromStr for Devices {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        let specs = if text.trim() == "cpu" {
            let cores = std::thread::available_parallelism().map_or(1, usize::from);
            vec![DeviceSpec::Cpu {
                count: 1,
                threads: cores,
            }]
        } else {
            raytrace::devices::parse_devices(text).map_err(|e| e.to_string())?
        };
        // Two CPU entries make more devices, but an adapter listed twice (or with `gpu:all`)
        // would be opened as two devices racing on one GPU.
        let same_adapter = |a: &DeviceSpec, b: &DeviceSpec| match (a, b) {
            (DeviceSpec::Gpu(x), DeviceSpec::Gpu(y)) => x == y || [x, y].contains(&&GpuSelect::All),
            _ => false,
        };
        if let Some((a, b)) = repeated(&specs, same_adapter) {
            return Err(format!("{a} and {b} name the same adapter twice"));
        }
        let (mut devices, mut threads) = (0usize, 0usize);
        for spec in &specs {
            if let DeviceSpec::Cpu { count, threads: t } = *spec {
                devices = devices.saturating_add(count);
                threads = threads.max(t);
            }
        }
        let total = specs.iter().try_fold(0usize, |sum, spec| match *spec {
            DeviceSpec::Cpu { count, threads } => count.checked_mul(threads)?.checked_add(sum),
            DeviceSpec::Gpu(_) => Some(sum),
        });
        let max_threads = crate::limits::MAX_THREADS;
        if devices > MAX_DEVICES || threads > MAX_DEVICES || total.is_none_or(|t| t > max_threads) {
            return Err(format!(
                "at most {MAX_DEVICES} devices, {MAX_DEVICES} threads per device and \
                 {max_threads} threads in all"
            ));
        }
        Ok(Self {
            text: text.to_string(),
            specs,
        })
    }
}

/// `DEVICE@WHEN` (or `DEVICE=WHAT`, as `at` says): a device index and what befalls it, `what`
/// naming `WHEN` in errors; `usage` is the error when there is no `at`.
fn device_at<T: FromStr>(
    text: &str,
    at: char,
    what: &str,
    usage: &str,
) -> Result<(usize, T), String> {
    let (device, when) = text.trim().split_once(at).ok_or(usage)?;
    let device = device
        .trim()
        .parse()
        .map_err(|_| format!("{device:?} is not a device index"))?;
    let when = when
        .trim()
        .parse()
        .map_err(|_| format!("{when:?} is not a {what}"))?;
    Ok((device, when))
}

/// One fault of `cobalt render --fail DEVICE@TASKS[,…]`: device DEVICE fails after TASKS
/// tasks. Whether the device exists depends on `--devices`: [`check_faults`].
pub fn fail_after(text: &str) -> Result<FailAfter, String> {
    let usage = "expected DEVICE@TASKS, e.g. 1@3 (device 1 fails after 3 tasks)";
    let (device, tasks) = device_at(text, '@', "task count", usage)?;
    Ok(FailAfter { device, tasks })
}

/// One slowed device of `cobalt render` and `cobalt bench --slow DEVICE=K[,…]`: device
/// DEVICE takes K times as long (K ≥ 1). Whether the device exists depends on `--devices`:
/// [`check_slow`].
pub fn slow_by(text: &str) -> Result<SlowBy, String> {
    let usage = "expected DEVICE=K, e.g. 1=50 (device 1 takes 50 times as long)";
    let (device, factor): (usize, f64) = device_at(text, '=', "number", usage)?;
    if !(factor.is_finite() && factor >= 1.0) {
        return Err(format!("the factor {factor} is not finite and at least 1"));
    }
    Ok(SlowBy { device, factor })
}

/// The devices of `--slow`, each an index below `devices` (`usize::MAX` where GPU entries
/// make the count known only once the devices are opened; an index beyond them slows none).
pub fn check_slow(slow: &[SlowBy], devices: usize) -> Result<Vec<SlowBy>, CliError> {
    let show = |s: &SlowBy| format!("{}={}", s.device, s.factor);
    distinct("slow", slow, |s| format!("device {}", s.device), show)?;
    check_devices("slow", slow, devices, |s| (s.device, show(s)))
}

/// `items` of `--FLAG`, each naming a device (`index`, with the item as typed) below `devices`.
fn check_devices<T: Clone>(
    flag: &'static str,
    items: &[T],
    devices: usize,
    index: impl Fn(&T) -> (usize, String),
) -> Result<Vec<T>, CliError> {
    match items.iter().map(&index).find(|(d, _)| *d >= devices) {
        Some((device, value)) => Err(CliError::Arg {
            flag,
            value,
            message: format!("no device {device}: there are {devices} (numbered from 0)"),
        }),
        None => Ok(items.to_vec()),
    }
}

/// The faults of `--fail`, each device an index below `devices` (`usize::MAX` where GPU
/// entries make the count known only once the devices are opened; they check it then).
pub fn check_faults(faults: &[FailAfter], devices: usize) -> Result<Vec<FailAfter>, CliError> {
    let faults = check_devices("fail", faults, devices, |f| {
        (f.device, format!("{}@{}", f.device, f.tasks))
    })?;
    // Two failure points for one device contradict each other: name both.
    let device = |f: &FailAfter| format!("device {}", f.device);
    distinct("fail", &faults, device, |f| {
        format!("{}@{}", f.device, f.tasks)
    })?;
    Ok(faults)
}

/// The first entry of `items` that `same` pairs with an earlier one, and that earlier one.
fn repeated<T>(items: &[T], same: impl Fn(&T, &T) -> bool) -> Option<(&T, &T)> {
    let mut pairs = items.iter().enumerate();
    pairs.find_map(|(i, f)| items[..i].iter().find(|g| same(g, f)).map(|g| (g, f)))
}

/// Refuses two entries of `--FLAG` with the same `key` (a policy, a task size, a device's
/// slowdown), naming both as `show` writes them: the second would silently repeat the first,
/// or contradict it.
pub fn distinct<T>(
    flag: &'static str,
    items: &[T],
    key: impl Fn(&T) -> String,
    show: impl Fn(&T) -> String,
) -> Result<(), CliError> {
    match repeated(items, |a, b| key(a) == key(b)) {
        Some((g, f)) => Err(CliError::Arg {
            flag,
            value: format!("{},{}", show(g), show(f)),
            message: format!("{} is listed twice", key(f)),
        }),
        None => Ok(()),
    }
}

/// A count `1..=MAX`: points, queries, bodies, neighbours, threads. The limit keeps a typo
/// such as an extra zero from allocating before the memory check can name it.
pub fn count<const MAX: usize>(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(n) if (1..=MAX).contains(&n) => Ok(n),
        _ => Err(format!("expected a whole number in 1..={MAX}")),
    }
}

/// One relative device speed of `cobalt schedule --speeds`; [`sched::Speeds`] checks the list.
pub fn speed(text: &str) -> Result<f64, String> {
    text.trim().parse().map_err(|_| {
        "expected a number, e.g. 2.5 (a device 2.5 times as fast as one of speed 1)".into()
    })
}

/// One fault of `cobalt schedule --fail DEVICE@TIME[,…]`: the device stops at a time in the
/// costs' unit, finite and non-negative. Whether the device exists depends on `--speeds`;
/// the simulation checks it.
pub fn fault_time(text: &str) -> Result<Fault, String> {
    let usage = "expected DEVICE@TIME, e.g. 1@0.5 (device 1 stops at time 0.5)";
    let (device, at): (usize, f64) = device_at(text, '@', "time", usage)?;
    if !(at.is_finite() && at >= 0.0) {
        return Err(format!("the time {at} is not finite and non-negative"));
    }
    Ok(Fault { device, at })
}

/// The scene and how its BVH is built.
#[derive(Debug, Clone, clap::Args)]
pub struct SceneArgs {
    /// An OBJ file, or `builtin:forest|hairball|cornell[:detail]`.
    #[arg(long)]
    pub scene: String,
    /// BVH build preset: fastest, very-fast, fast, medium, slow, very-slow, sah, or auto
    /// (sah, or medium for a scene whose largest 1% of triangles hold over half their area).
    #[arg(long, default_value = "auto")]
    pub preset: BuildPreset,
}

/// Where the camera is: one of the four orbit cameras, or an eye and a point looked at.
#[derive(Debug, Clone, clap::Args)]
pub struct CameraArgs {
    /// One of the four orbit cameras, 0..3 (at the top of the scene's bounding box, looking
    /// at its centre); the default when no `--eye`/`--at` is given.
    #[arg(long, conflicts_with_all = ["eye", "at"], allow_hyphen_values = true,
          value_parser = camera_index)]
    pub camera: Option<usize>,
    /// Camera position `X,Y,Z` (with `--at`).
    #[arg(long, requires = "at", allow_hyphen_values = true, value_parser = point)]
    pub eye: Option<Vec3>,
    /// Point looked at `X,Y,Z` (with `--eye`).
    #[arg(long, requires = "eye", allow_hyphen_values = true, value_parser = point)]
    pub at: Option<Vec3>,
}

/// Where the camera comes from, checked.
#[derive(Debug, Clone, Copy)]
pub enum CameraChoice {
    /// One of the four orbit cameras around the scene.
    Orbit(usize),
    /// An eye and a different point it looks at.
    LookAt(Vec3, Vec3),
}

impl CameraArgs {
    /// The camera asked for: the eye must differ from the point it looks at.
    pub fn choice(&self) -> Result<CameraChoice, CliError> {
        match (self.camera, self.eye, self.at) {
            (_, Some(eye), Some(at)) if eye == at => Err(CliError::Arg {
                flag: "at",
                value: format!("{},{},{}", at.x, at.y, at.z),
                message: "the camera cannot look at its own position".into(),
            }),
            (_, Some(eye), Some(at)) => Ok(CameraChoice::LookAt(eye, at)),
            (camera, _, _) => Ok(CameraChoice::Orbit(camera.unwrap_or(0))),
        }
    }
}

impl CameraChoice {
    /// The camera for `scene` (`--eye` and `--at` are in the source's units), and the orbit
    /// camera's index if it is one.
    pub fn resolve(&self, scene: &raytrace::Scene) -> (Camera, Option<usize>) {
        match *self {
            CameraChoice::Orbit(i) => (Camera::orbit(&scene.bounds(), i), Some(i)),
            CameraChoice::LookAt(eye, at) => {
                let camera = Camera::look_at(scene.to_scene(eye), scene.to_scene(at));
                (camera, None)
            }
        }
    }
}

/// Which shader.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ShaderKind {
    /// Ambient occlusion: Halton rays per hit (the diffuse workload).
    Ao,
    /// Whitted: shadow rays and two mirror bounces (the coherent workload).
    Whitted,
}

/// The shader and its settings.
#[derive(Debug, Clone, clap::Args)]
pub struct ShaderArgs {
    /// The shader.
    #[arg(long, value_enum, default_value = "whitted")]
    pub shader: ShaderKind,
    /// AO rays per primary hit, 1..=4096.
    #[arg(long, default_value = "32",
          value_parser = clap::value_parser!(u32).range(1..=MAX_AO_SAMPLES as i64))]
    pub ao_samples: u32,
    /// AO ray length (default: 5 % of the scene's bounding-box diagonal).
    #[arg(long, value_parser = positive_length)]
    pub ao_distance: Option<f32>,
}

impl ShaderKind {
    /// The shader, AO with `ao_samples` rays per hit of `ao_distance` (default: the scene's).
    pub fn shader(self, ao_samples: u32, ao_distance: Option<f32>) -> raytrace::shade::Shader {
        use raytrace::shade::{AoSettings, Shader, WhittedSettings};
        match self {
            ShaderKind::Ao => Shader::Ao(AoSettings {
                samples: ao_samples,
                max_distance: ao_distance,
                ..Default::default()
            }),
            ShaderKind::Whitted => Shader::Whitted(WhittedSettings::default()),
        }
    }
}

impl ShaderArgs {
    /// The shader these settings make.
    pub fn shader(&self) -> raytrace::shade::Shader {
        self.shader.shader(self.ao_samples, self.ao_distance)
    }
}

/// The devices, and how tasks are cut, costed and planned over them.
#[derive(Debug, Clone, clap::Args)]
pub struct ScheduleArgs {
    /// Devices: `cpu:N` (N devices of one thread), `cpu:N/T` (T threads each), several
    /// comma-separated, or `cpu` (one device with every core); `gpu:all` or `gpu:K` adds wgpu
    /// adapters (software ones only with `COBALT_GPU_SOFTWARE=1`). At most 1024 CPU devices,
    /// 1024 threads each and 4096 threads in all.
    #[arg(long, default_value = "cpu:2")]
    pub devices: Devices,
    /// How tasks go to devices: static-equal, static-lpt (lpt), queue-fifo (fifo),
    /// queue-sorted (sorted) or hybrid.
    #[arg(long, default_value = "static-lpt")]
    pub policy: Policy,
    /// Task costs: `cost` (estimated from a sample of each task) or `regular` (all equal).
    #[arg(long, default_value = "cost")]
    pub mode: Mode,
    /// Paths (pixels) per task; a frame too small to give every device four tasks is cut
    /// finer.
    #[arg(long, default_value = "4096", value_parser = task_size)]
    pub task_size: NonZeroUsize,
    /// Fraction of each task's paths the cost estimate samples, in (0, 1] (default: 1/64 for
    /// `whitted`, 1/32 for `ao`).
    #[arg(long, value_parser = sample_rate)]
    pub sample_rate: Option<SampleRate>,
    /// How the estimate counts a sampled path, on the devices: `trace` (rendered for real,
    /// counted), or its camera ray walked by `reduced` (the thesis's reduced traversal) or
    /// `first-leaf` (up to the first leaf it reaches).
    #[arg(long, default_value = "trace")]
    pub walk: Walk,
    /// Run the plan as planned: no device left idle runs backup copies of the tasks another
    /// device holds (the thesis's pure static behaviour).
    #[arg(long)]
    pub no_backups: bool,
}

impl ScheduleArgs {
    /// The engine's settings these flags give.
    pub fn settings(&self) -> Settings {
        Settings {
            policy: self.policy,
            mode: self.mode,
            task_size: self.task_size,
            sample_rate: self.sample_rate,
            walk: self.walk,
            backups: !self.no_backups,
        }
    }
}

/// Where the results go besides the summary.
#[derive(Debug, Clone, clap::Args)]
pub struct ReportArgs {
    /// A JSON report, written to this file.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Print the report as one JSON object on standard output instead of a summary.
    #[arg(long)]
    pub json: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_name_the_bad_side() {
        assert_eq!(
            "64x32".parse::<Size>(),
            Ok(Size {
                width: 64,
                height: 32
            })
        );
        assert_eq!(Size::square(8).to_string(), "8x8");
        for bad in ["0x32", "32", "32xlots", "16385x1"] {
            assert!(bad.parse::<Size>().is_err(), "{bad}");
        }
    }

    #[test]
    fn slowed_devices_are_parsed_and_checked() {
        assert_eq!(
            slow_by("1=50"),
            Ok(SlowBy {
                device: 1,
                factor: 50.0
            })
        );
        for bad in ["1", "x=2", "1=0.5", "1=inf", "1@2"] {
            assert!(slow_by(bad).is_err(), "{bad}");
        }
        let slow = [slow_by("2=4").expect("valid")];
        assert!(check_slow(&slow, 3).is_ok());
        let err = check_slow(&slow, 2).expect_err("no device 2").to_string();
        assert!(
            err.contains("--slow") && err.contains("no device 2"),
            "{err}"
        );
    }

    #[test]
    fn faults_are_checked_against_the_devices() {
        let twice = [
            fail_after("0@0").expect("valid"),
            fail_after("0@1").expect("valid"),
        ];
        let err = check_faults(&twice, 2).expect_err("one device, two failure points");
        assert!(err.to_string().contains("0@0,0@1"), "{err}");
        let f = [fail_after("1@3").expect("valid")];
        assert!(check_faults(&f, 2).is_ok());
        let err = check_faults(&f, 1).expect_err("no device 1").to_string();
        assert!(
            err.contains("--fail \"1@3\"") && err.contains("no device 1"),
            "{err}"
        );
        for bad in ["1", "0@x", "x@1"] {
            assert!(fail_after(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn schedule_list_items_and_counts_are_checked() {
        assert_eq!(speed(" 2.5"), Ok(2.5));
        assert!(speed("").is_err() && speed("x").is_err());
        let f = fault_time(" 1@0.5").expect("valid");
        assert_eq!((f.device, f.at), (1, 0.5));
        for bad in ["1", "x@1", "1@-1", "1@inf"] {
            assert!(fault_time(bad).is_err(), "{bad}");
        }
        assert_eq!(count::<4>("4"), Ok(4));
        assert!(count::<4>("5").is_err() && count::<4>("0").is_err());
    }

    #[test]
    fn devices_are_bounded() {
        let d: Devices = "cpu:2/3,cpu:1".parse().expect("valid");
        assert_eq!((d.cpu_devices(), d.has_gpu()), (3, false));
        assert!("cpu:1024/1024".parse::<Devices>().is_err());
        assert!("tpu".parse::<Devices>().is_err());
    }
}
