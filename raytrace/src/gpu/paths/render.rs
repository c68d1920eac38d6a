//! A GPU device's launch of whole paths: for a list of tasks (ranges of paths in the image's
//! Morton order), primary rays made on the device, closest hits, ambient-occlusion probes
//! with the CPU's Halton points, any hits, and each path's value, every stage a kernel over
//! device buffers (`render.wgsl`, with the traces of the trace kernels on the compressed wide
//! tree, `traverse_wide.wgsl`; Whitted shading is `whitted.rs`). A launch is one submission
//! (see `launch.rs`): what crosses the bus is the task list and the launch's parameters on the
//! way in, and on the way out, in the launch's single read-back, the paths' values with each
//! trace's queue state.
//!
//! The values equal [`crate::shade::render`]'s up to the differences `render.wgsl` lists
//! (`cos`/`sin` rounding, exact-edge ties): a pixel is a fraction of probes, so a probe that
//! changes its verdict moves a pixel by `1/samples`. Probes are generated in chunks of
//! primaries that fit one binding, so a launch whose primary rays fit one binding renders.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::shading::with_shading;
use super::sums::sums_kernel;
use super::whitted_kernels::WhittedKernels;
use crate::bvh::Bvh;
use crate::gpu::GpuError;
use crate::gpu::buffers::{GpuRay, RESULT_BYTES, check_size, fetch, init, rays_per_launch};
use crate::gpu::context::GpuContext;
use crate::gpu::header::{self, Header, Setup, task_list};
use crate::gpu::launch::{Count, Recorder, verdict_kernel};
use crate::gpu::program::{Kernel, Program, READ, UNIFORM, WRITE};
use crate::gpu::resident::Resident;
use crate::gpu::trace::{ANY, BinaryWalks, CLOSEST, TraceDevice, loop_cut};
use crate::paths::Launch;
use crate::scene::Scene;
use crate::shade::{AoSettings, RenderOptions};
use crate::traffic::Traffic;
use crate::traverse::layout::Layout;
use crate::traverse::walk::Walk;

/// The uniform block of `render.wgsl` (`struct Params`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(in crate::gpu) struct Params {
    eye: [f32; 4],
    fwd: [f32; 4],
    right: [f32; 4],
    up: [f32; 4],
    plane_w: f32,
    plane_h: f32,
    max_distance: f32,
    gamma8: f32,
    width: u32,
    height: u32,
    samples: u32,
    base: u32,
    seed_lo: u32,
    seed_hi: u32,
    stride: u32,
    pad: u32,
    // The launch's counts, copied in on the device from its header (see `resident.rs`).
    count: u32,
    chunk: u32,
    tasks: u32,
    pad1: u32,
}

const _: () = assert!(size_of::<Params>() == 128);

impl Params {
    /// Byte offset of `count`, `chunk` and `tasks`, the header's first three words.
    const COUNTS: u64 = 112;

    /// The block without the launch's counts: what stays the same across a frame's launches.
    fn frame_part(&self) -> Self {
        Self {
            count: 0,
            chunk: 0,
            tasks: 0,
            ..*self
        }
    }
}

/// A scene triangle by primitive id (`struct SceneTri`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct SceneTri {
    v: [[f32; 4]; 3],
}

/// One GPU with a scene and the path kernels: renders ranges of paths entirely on the
/// device.
#[derive(Debug)]
pub struct GpuRenderer {
    /// The tree every trace of a render walks: the compressed wide one unless asked otherwise.
    pub(in crate::gpu) dev: TraceDevice,
    /// The binary tree the thesis's walks count, when `dev` holds a wide one.
    pub(in crate::gpu) walks: Option<BinaryWalks>,
    pub(in crate::gpu) tris: wgpu::Buffer,
    pub(super) whitted: WhittedKernels,
    program: Program,
    pub(in crate::gpu) raygen: wgpu::ComputePipeline,
    shade_ao: wgpu::ComputePipeline,
    accumulate: wgpu::ComputePipeline,
    /// The scene's bounding-box diagonal, for the default probe length.
    diagonal: f32,
    /// The scene's [`Scene::unit`], for a probe length given in the source's units.
    unit: i32,
    /// Buffers and parameters kept across launches and frames.
    pub(in crate::gpu) resident: Resident,
    verdict: Kernel,
    /// Makes each launch's counts from its task list.
    header: Kernel,
    /// The per-task sums of an estimate's sample.
    pub(in crate::gpu) path_sums: Kernel,
    /// Launches record no dispatch of their traces, as an implementation that cut every loop
    /// short would: the verdict must see it.
    #[cfg(test)]
    pub(in crate::gpu) starved: bool,
}

impl GpuRenderer {
    /// Uploads `scene` (its triangles by primitive id, for shading) and `bvh` (built from it)
    /// and compiles the kernels. The traces walk the compressed 8-wide tree (a wide tree
    /// with no compressed form, the binary one); an estimate by the thesis's walks counts the
    /// binary tree, uploaded beside it.
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] when a scene buffer exceeds a binding limit,
    /// [`GpuError::TooDeep`] beyond the deepest supported tree.
    pub fn new(ctx: GpuContext, scene: &Scene, bvh: &Bvh) -> Result<Self, GpuError> {
        match Self::with_layout(ctx.clone(), scene, bvh, Layout::Wide) {
            Err(GpuError::Compress(_)) => Self::with_layout(ctx, scene, bvh, Layout::Binary),
            made => made,
        }
    }

    /// [`GpuRenderer::new`] with every trace walking `layout`'s tree (the path kernels are
    /// the same for both).
    ///
    /// # Errors
    /// Those of [`GpuRenderer::new`], and [`GpuError::Compress`] for a wide tree with no
    /// compressed form.
    pub fn with_layout(
        ctx: GpuContext,
        scene: &Scene,
        bvh: &Bvh,
        layout: Layout,
    ) -> Result<Self, GpuError> {
        let dev = TraceDevice::with_layout(ctx, bvh, layout)?;
        let walks = (layout == Layout::Wide).then(|| BinaryWalks::new(&dev.ctx, bvh));
        let ctx = &dev.ctx;
        let mut tris: Vec<SceneTri> = (0..scene.len())
            .map(|prim| SceneTri {
                v: scene.vertices(prim).map(|p| p.extend(0.0).to_array()),
            })
            .collect();
        if tris.is_empty() {
            // A binding may not be empty; nothing reads it when nothing is hit.
            tris.push(SceneTri::default());
        }
        let tri_bytes: &[u8] = bytemuck::cast_slice(&tris);
        check_size(ctx, "scene triangles", tri_bytes.len() as u64)?;
        let device = &ctx.device;
        let tris = init(
            device,
            "cobalt scene triangles by id",
            tri_bytes,
            wgpu::BufferUsages::STORAGE,
        );
        let program = Program::new(
            device,
            "render",
            with_shading(include_str!("render.wgsl")),
            &[UNIFORM, WRITE, WRITE, READ, READ, WRITE, READ, WRITE, READ],
        );
        let make = |entry: &str, label: &str| program.pipeline(device, entry, label);
        let whitted = WhittedKernels::new(ctx, scene);
        let verdict = verdict_kernel(device);
        let path_sums = sums_kernel(device);
        let header = header::header_kernel(device);
        Ok(Self {
            walks,
            whitted,
            raygen: make("raygen", "cobalt raygen pipeline"),
            shade_ao: make("shade_ao", "cobalt AO shading pipeline"),
            accumulate: make("accumulate", "cobalt AO accumulate pipeline"),
            program,
            tris,
            diagonal: scene.bounds().extent().length(),
            unit: scene.unit,
            resident: Resident::default(),
            verdict,
            header,
            path_sums,
            dev,
            #[cfg(test)]
            starved: false,
        })
    }

    /// The opened adapter.
    pub fn context(&self) -> &GpuContext {
        &self.dev.ctx
    }

    /// The tree the traces of a render walk.
    pub fn layout(&self) -> Layout {
        self.dev.layout
    }

    /// Checks the image and the launch, uploads its task list and number of tasks (`secondary`
    /// secondary rays per path of the first chunk: AO probes, or shadow rays), keeps the
    /// frame's parameters, and binds the launch's buffers with them (its first chunk of
    /// probes): `raygen` over that group makes the primary rays. A launch holds every
    /// `stride`-th path of each task, from its first (1 to render; the sample to estimate).
    pub(in crate::gpu) fn begin(
        &self,
        frame: &RenderOptions,
        tasks: &[&Range<usize>],
        settings: &AoSettings,
        secondary: u32,
        stride: u32,
        traffic: &mut Traffic,
    ) -> Result<(Stage, wgpu::BindGroup), GpuError> {
        let ctx = &self.dev.ctx;
        let (width, height) = (frame.width, frame.height);
        let too_large =
            |what: &'static str, bytes: u64, limit: &'static str, max: u64| GpuError::TooLarge {
                adapter: ctx.info.name.clone(),
                what,
                bytes,
                limit,
                max,
            };
        let side = 1u32 << 16;
        if !(1..=side).contains(&width) || !(1..=side).contains(&height) {
            return Err(too_large(
                "image sides (Morton order)",
                u64::from(width.max(height)),
                "65536 pixels a side",
                u64::from(side),
            ));
        }
        let pixels = u64::from(width) * u64::from(height);
        let stride = stride.max(1);
        let n = Header::slots(tasks, stride);
        let per_launch = rays_per_launch(&ctx.limits) as u64;
        if n > per_launch {
            return Err(too_large(
                "primary rays of a launch",
                n * size_of::<GpuRay>() as u64,
                "max_storage_buffer_binding_size",
                per_launch * size_of::<GpuRay>() as u64,
            ));
        }
        if let Some(t) = tasks
            .iter()
            .find(|t| t.start > t.end || t.end as u64 > pixels)
        {
            return Err(too_large(
                "paths of a task",
                t.end as u64,
                "the image's pixels",
                pixels,
            ));
        }
        let samples = settings.samples;
        // Primaries per probe chunk: their probes must fit one binding.
        let fit = match samples {
            0 => u32::MAX,
            s => u32::try_from((per_launch / u64::from(s)).max(1)).unwrap_or(u32::MAX),
        };
        let setup = Setup::new(stride, fit, secondary);
        // Slots are below the binding limit (checked above), so only a list of more than
        // 2^32 tasks, empty ones, could overflow.
        let header = Header::of(tasks, &setup).ok_or_else(|| {
            too_large(
                "tasks of a launch",
                tasks.len() as u64,
                "2^32 tasks",
                1 << 32,
            )
        })?;
        let (n, chunk) = (header.count, header.chunk);
        let probe_slots = u64::from(chunk) * u64::from(samples.max(1));
        check_size(ctx, "AO probes", probe_slots * size_of::<GpuRay>() as u64)?;
        let f = frame.camera.frame(width, height);
        let v4 = |v: Vec3| v.extend(0.0).to_array();
        let params = Params {
            eye: v4(frame.camera.eye),
            fwd: v4(f.forward),
            right: v4(f.right),
            up: v4(f.up),
            plane_w: f.half_width,
            plane_h: f.half_height,
            max_distance: settings.probe_length(self.diagonal, self.unit),
            gamma8: crate::spawn::gamma(8),
            width,
            height,
            samples,
            base: 0,
            // The seed's two words.
            seed_lo: settings.seed as u32,
            seed_hi: (settings.seed >> 32) as u32,
            stride,
            pad: 0,
            count: header.count,
            chunk: header.chunk,
            tasks: header.tasks,
            pad1: 0,
        };
        let storage = |label: &'static str, size: u64, usage| self.scratch(label, size, usage);
        let none = wgpu::BufferUsages::empty();
        let copy = wgpu::BufferUsages::COPY_SRC;
        let ray_bytes = size_of::<GpuRay>() as u64;
        let resident = &self.resident;
        let stage = Stage {
            n,
            chunk,
            params,
            header: resident.upload(
                ctx,
                "cobalt launch header",
                Header::TASKS,
                bytemuck::bytes_of(&header.tasks),
                traffic,
            ),
            setup: resident.uniform(
                ctx,
                ("cobalt launch setup", stride),
                bytemuck::bytes_of(&setup),
                traffic,
            ),
            uniform: resident.uniform(
                ctx,
                // A sample's block (its stride) and the render's are kept side by side.
                ("cobalt path parameters", stride),
                bytemuck::bytes_of(&params.frame_part()),
                traffic,
            ),
            primary: storage("cobalt primary rays", u64::from(n) * ray_bytes, copy),
            ranks: storage("cobalt path ranks", u64::from(n) * 4, copy),
            hits: storage("cobalt primary hits", u64::from(n) * RESULT_BYTES, none),
            probes: storage("cobalt AO probes", probe_slots * ray_bytes, none),
            probe_hits: storage("cobalt AO probe hits", probe_slots * RESULT_BYTES, none),
            film: storage("cobalt path values", u64::from(n) * 4, copy),
            tasks: resident.upload(
                ctx,
                "cobalt launch tasks",
                0,
                bytemuck::cast_slice(&task_list(tasks)),
                traffic,
            ),
        };
        let group = self.bind(&stage, &stage.uniform);
        Ok((stage, group))
    }

    /// A launch's recorder on this device (see [`Recorder`]), its first commands making the
    /// launch's counts from its task list (`header.wgsl`) and copying them into the frame's
    /// parameters.
    pub(in crate::gpu) fn recorder(&self, stage: &Stage, checked: bool) -> Recorder<'_> {
        let mut launch = Recorder::new(&self.dev, &self.verdict, checked);
        header::record(
            &self.header,
            &mut launch,
            &self.dev.ctx.device,
            [&stage.header, &stage.tasks, &stage.setup],
        );
        launch.copy(
            &stage.header,
            Header::COUNT,
            &stage.uniform,
            Params::COUNTS,
            12,
        );
        #[cfg(test)]
        {
            launch.starved = self.starved;
        }
        launch
    }

    /// A storage buffer of at least `size` bytes kept for later launches (see
    /// [`Resident::scratch`]).
    pub(in crate::gpu) fn scratch(
        &self,
        label: &'static str,
        size: u64,
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        self.resident
            .scratch(&self.dev.ctx.device, label, size, usage)
    }

    /// A bind group of `stage`'s buffers with the parameters `uniform`.
    fn bind(&self, stage: &Stage, uniform: &wgpu::Buffer) -> wgpu::BindGroup {
        self.program.bind(
            &self.dev.ctx.device,
            "cobalt render bind group",
            &[
                uniform,
                &stage.primary,
                &stage.ranks,
                &stage.hits,
                &self.tris,
                &stage.probes,
                &stage.probe_hits,
                &stage.film,
                &stage.tasks,
            ],
        )
    }

    /// The paths of `tasks` with ambient occlusion (see [`GpuRenderer::render`]):
    /// `settings.samples` probes per primary hit, each path's probes seeded by its rank, so a
    /// path's value does not depend on the launch it is in.
    pub(in crate::gpu) fn render_ao(
        &self,
        frame: &RenderOptions,
        tasks: &[&Range<usize>],
        settings: &AoSettings,
    ) -> Result<Launch, GpuError> {
        let samples = settings.samples;
        let grey: fn(&[u8]) -> Vec3 = |c| Vec3::splat(bytemuck::pod_read_unaligned::<f32>(c));
        self.drained(|checked| {
            let values = (Vec3::ONE, 4, grey);
            self.launch(
                frame,
                tasks,
                (settings, samples),
                checked,
                values,
                |l, s, g, t| self.record_ao(l, s, g, samples, None, t),
            )
        })
    }

    /// What `launch(false)` gives, one submission; should a queue not be drained (`None`),
    /// what `launch(true)` gives, the host checking every trace.
    ///
    /// # Errors
    /// Those of `launch`, and [`GpuError::LoopCut`] when even the checked launch says `None`.
    pub(in crate::gpu) fn drained<T>(
        &self,
        launch: impl Fn(bool) -> Result<Option<T>, GpuError>,
    ) -> Result<T, GpuError> {
        match launch(false)? {
            Some(out) => Ok(out),
            None => launch(true)?.ok_or_else(|| loop_cut(&self.dev.ctx.info.name)),
        }
    }

    /// One launch of paths of `tasks` with the probes of `settings` and `secondary`
    /// secondary rays per path (see [`GpuRenderer::begin`]), recorded as one submission
    /// (`checked`: the host checks each trace) by `record`, which returns the buffer of the
    /// paths' values and the rays traced; `None` when a trace's queue was found not drained.
    /// A value is `bytes` long, read by `value`; in an empty scene every primary misses and
    /// sees `sky`.
    pub(in crate::gpu) fn launch(
        &self,
        frame: &RenderOptions,
        tasks: &[&Range<usize>],
        (settings, secondary): (&AoSettings, u32),
        checked: bool,
        (sky, bytes, value): Values,
        record: impl FnOnce(
            &mut Recorder<'_>,
            &Stage,
            &wgpu::BindGroup,
            &mut Traffic,
        ) -> Result<(wgpu::Buffer, usize), GpuError>,
    ) -> Result<Option<Launch>, GpuError> {
        let mut traffic = Traffic::default();
        let (stage, first) = self.begin(frame, tasks, settings, secondary, 1, &mut traffic)?;
        let n = stage.n;
        if self.dev.scene.empty {
            return Ok(Some(Launch {
                values: vec![sky; n as usize],
                rays: n as usize,
                device_seconds: None,
                traffic,
                film_bytes: 0,
            }));
        }
        let mut launch = self.recorder(&stage, checked);
        let (film, rays) = record(&mut launch, &stage, &first, &mut traffic)?;
        let film_bytes = u64::from(n) * bytes;
        let done = launch.finish(&film, film_bytes, &mut traffic)?;
        if !done.drained {
            return Ok(None);
        }
        // One pass from the bytes read back: each copy of a frame's values is a pass over
        // fresh pages.
        Ok(Some(Launch {
            values: done
                .values
                .chunks_exact(bytes as usize)
                .map(value)
                .collect(),
            rays,
            device_seconds: done.kernel_seconds,
            traffic,
            film_bytes,
        }))
    }

    /// Records an AO launch of `stage` (`first`: its first chunk's bind group) into `launch`:
    /// raygen, the primaries' trace, and per chunk the probes, their trace and the paths'
    /// values. With `tally`, every trace adds its rays' counts to their paths' entries and
    /// no value is made (an estimate's launch, whose probes fit one chunk; the camera rays
    /// alone without probes). Returns the buffer of the paths' values and the rays traced.
    pub(in crate::gpu) fn record_ao(
        &self,
        launch: &mut Recorder<'_>,
        stage: &Stage,
        first: &wgpu::BindGroup,
        samples: u32,
        tally: Option<&Tally>,
        traffic: &mut Traffic,
    ) -> Result<(wgpu::Buffer, usize), GpuError> {
        let n = stage.n;
        launch.pass_over(&self.raygen, first, n);
        let header = &stage.header;
        launch.trace(
            &stage.primary,
            &stage.hits,
            n,
            tally.map_or(CLOSEST, |t| t.primary),
            match tally {
                Some(t) => Count::Counted {
                    counts: &t.paths,
                    per_path: 1,
                },
                None => Count::Copied(header, Header::COUNT),
            },
            traffic,
        )?;
        let mut base = 0;
        while base < n {
            let len = stage.chunk.min(n - base);
            let params = Params {
                base,
                chunk: len,
                ..stage.params
            };
            // The first chunk's parameters are the launch's; a later chunk (of a launch whose
            // probes do not fit one binding) uploads its own.
            let other = (base > 0).then(|| {
                traffic.host_to_device_bytes += size_of::<Params>() as u64;
                let uniform = init(
                    &self.dev.ctx.device,
                    "cobalt path chunk parameters",
                    bytemuck::bytes_of(&params),
                    wgpu::BufferUsages::UNIFORM,
                );
                self.bind(stage, &uniform)
            });
            let group = other.as_ref().unwrap_or(first);
            if samples > 0 {
                launch.pass_over(&self.shade_ao, group, len);
                launch.trace(
                    &stage.probes,
                    &stage.probe_hits,
                    len * samples,
                    ANY,
                    match tally {
                        Some(t) => Count::Counted {
                            counts: &t.probes,
                            per_path: samples,
                        },
                        None if base == 0 => Count::Copied(header, Header::SECONDARY),
                        None => Count::Uploaded,
                    },
                    traffic,
                )?;
            }
            if tally.is_none() {
                launch.pass_over(&self.accumulate, group, len);
            }
            base += len;
        }
        Ok((stage.film.clone(), n as usize * (1 + samples as usize)))
    }

    /// The primary rays a launch of `tasks` of `frame`'s image generates on the device, read
    /// back (the CPU's [`crate::Camera::primary_rays_of`]), with each one's rank.
    ///
    /// # Errors
    /// As [`GpuRenderer::render`].
    pub fn primary_rays(
        &self,
        frame: &RenderOptions,
        tasks: &[&Range<usize>],
    ) -> Result<(Vec<GpuRay>, Vec<u32>), GpuError> {
        let mut traffic = Traffic::default();
        let (stage, group) =
            self.begin(frame, tasks, &AoSettings::default(), 0, 1, &mut traffic)?;
        let mut launch = self.recorder(&stage, false);
        launch.pass_over(&self.raygen, &group, stage.n);
        launch.finish(&stage.film, 0, &mut traffic)?;
        let n = u64::from(stage.n);
        let rays = fetch(
            &self.dev.ctx,
            &stage.primary,
            n * size_of::<GpuRay>() as u64,
        )?;
        let ranks = fetch(&self.dev.ctx, &stage.ranks, n * 4)?;
        Ok((
            bytemuck::pod_collect_to_vec(&rays),
            bytemuck::pod_collect_to_vec(&ranks),
        ))
    }
}

/// How a launch's values are read back: what every path sees in an empty scene, the bytes
/// of one value, and how one is read.
pub(in crate::gpu) type Values = (Vec3, u64, fn(&[u8]) -> Vec3);

/// Where an estimate's launch adds its rays' counts `B` and `T`: two words a path slot, the
/// primary, mirror and shadow rays' in `paths`, the AO probes' in `probes`; the camera rays
/// counted by `primary` (the closest-hit trace, or a reduced walk's counting mode).
pub(in crate::gpu) struct Tally {
    pub(in crate::gpu) paths: wgpu::Buffer,
    pub(in crate::gpu) probes: wgpu::Buffer,
    pub(in crate::gpu) primary: Walk,
}

/// The buffers of one launch, on the device.
pub(in crate::gpu) struct Stage {
    /// Paths of the launch (slots).
    pub(in crate::gpu) n: u32,
    /// Primaries whose probes are traced together.
    pub(in crate::gpu) chunk: u32,
    pub(in crate::gpu) params: Params,
    /// The launch's counts ([`Header`]), its third word sent, the others made on the device.
    pub(in crate::gpu) header: wgpu::Buffer,
    /// The frame-constant inputs of the header's kernel ([`Setup`]).
    pub(in crate::gpu) setup: wgpu::Buffer,
    /// The frame's parameters, kept across launches, with the launch's counts.
    pub(in crate::gpu) uniform: wgpu::Buffer,
    pub(in crate::gpu) primary: wgpu::Buffer,
    pub(in crate::gpu) ranks: wgpu::Buffer,
    pub(in crate::gpu) hits: wgpu::Buffer,
    pub(in crate::gpu) probes: wgpu::Buffer,
    pub(in crate::gpu) probe_hits: wgpu::Buffer,
    pub(in crate::gpu) film: wgpu::Buffer,
    pub(in crate::gpu) tasks: wgpu::Buffer,
}
