//! A render that never leaves the GPU between stages (issue 5): primary rays generated in
//! Morton order, closest hits, ambient-occlusion probes with the CPU's Halton points, any
//! hits, and the image, each a kernel over device buffers (`render.wgsl`, with the traces of
//! `traverse.wgsl`). Only the queue's state (8 bytes per trace round) is read back before the
//! finished image.
//!
//! The image equals [`crate::shade::render`]'s with [`crate::shade::Shader::Ao`] up to the
//! differences `render.wgsl` lists (`cos`/`sin` rounding, exact-edge ties): a pixel is a
//! fraction of probes, so a probe that changes its verdict moves a pixel by `1/samples`.
//! Probes are generated in chunks of primaries that fit one binding, so images of any size
//! whose primary rays fit one binding render.

use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::buffers::{
    GpuRay, RESULT_BYTES, SceneBuffers, check_size, fetch, init, rays_per_launch, storage,
};
use super::pipeline::{GpuMode, Kernels, Threads, grid, trace_resident};
use super::program::{Program, READ, UNIFORM, WRITE, dispatch, with_shading};
use super::{GpuContext, GpuError};
use crate::shade::AoSettings;
use crate::{Bvh, Camera, Film, Scene};

/// The uniform block of `render.wgsl` (`struct Params`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(super) struct Params {
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
    count: u32,
    samples: u32,
    base: u32,
    chunk: u32,
    seed_lo: u32,
    seed_hi: u32,
}

const _: () = assert!(size_of::<Params>() == 112);

/// A scene triangle by primitive id (`struct SceneTri`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct SceneTri {
    v: [[f32; 4]; 3],
}

/// What a GPU render produced.
#[derive(Clone, Debug)]
pub struct GpuRendering {
    /// The image (linear grey, as the CPU's AO render).
    pub film: Film,
    /// Primary rays traced.
    pub primary_rays: usize,
    /// Ray slots traced after the primaries: `samples` AO probes per primary ray, or per
    /// bounce one shadow ray per light and one mirror ray per pixel (slots of paths that ended
    /// hold empty-range rays, which end at once and add nothing).
    pub secondary_rays: usize,
    /// Kernel time of the traces from timestamp queries, where the device has them.
    pub trace_gpu_seconds: Option<f64>,
    /// Wall time of the whole render, uploads and the image's read-back included.
    pub seconds: f64,
}

/// One GPU with a scene and the render kernels: renders ambient occlusion entirely on the
/// device.
#[derive(Debug)]
pub struct GpuRenderer {
    pub(super) ctx: GpuContext,
    pub(super) kernels: Kernels,
    pub(super) scene: SceneBuffers,
    pub(super) tris: wgpu::Buffer,
    pub(super) whitted: super::whitted::WhittedKernels,
    program: Program,
    raygen: wgpu::ComputePipeline,
    shade_ao: wgpu::ComputePipeline,
    accumulate: wgpu::ComputePipeline,
    pub(super) threads: Threads,
    /// The scene's bounding-box diagonal, for the default probe length.
    diagonal: f32,
}

impl GpuRenderer {
    /// Traces `count` rays already on the device from `rays` into `out` (both renderers'
    /// traces): the GPU seconds, where timestamps measured them.
    pub(super) fn trace(
        &self,
        rays: &wgpu::Buffer,
        out: &wgpu::Buffer,
        count: u32,
        mode: GpuMode,
    ) -> Result<Option<f64>, GpuError> {
        trace_resident(
            &self.ctx,
            &self.kernels,
            &self.scene,
            rays,
            out,
            count,
            mode,
            self.threads,
        )
    }

    /// Uploads `scene` (its triangles by primitive id, for shading) and `bvh` (built from it)
    /// and compiles the kernels.
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] when a scene buffer exceeds a binding limit,
    /// [`GpuError::TooDeep`] beyond the deepest supported tree.
    pub fn new(ctx: GpuContext, scene: &Scene, bvh: &Bvh) -> Result<Self, GpuError> {
        let kernels = Kernels::new(&ctx.device, bvh.depth())?;
        let scene_buffers = SceneBuffers::upload(&ctx, bvh)?;
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
        check_size(&ctx, "scene triangles", tri_bytes.len() as u64)?;
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
            &[UNIFORM, WRITE, WRITE, READ, READ, READ, WRITE, READ, WRITE],
        );
        let make = |entry: &str, label: &str| program.pipeline(device, entry, label);
        let whitted = super::whitted::WhittedKernels::new(&ctx, scene);
        Ok(Self {
            whitted,
            raygen: make("raygen", "cobalt raygen pipeline"),
            shade_ao: make("shade_ao", "cobalt AO shading pipeline"),
            accumulate: make("accumulate", "cobalt AO accumulate pipeline"),
            program,
            tris,
            diagonal: scene.bounds().extent().length(),
            ctx,
            kernels,
            scene: scene_buffers,
            threads: Threads::default(),
        })
    }

    /// The same renderer tracing with `threads` (persistent threads by default).
    pub fn with_threads(self, threads: Threads) -> Self {
        Self { threads, ..self }
    }

    /// The opened adapter.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Checks the image, creates the buffers of a render and generates the primary rays.
    pub(super) fn begin(
        &self,
        width: u32,
        height: u32,
        camera: &Camera,
        settings: &AoSettings,
    ) -> Result<Stage, GpuError> {
        let ctx = &self.ctx;
        let device = &ctx.device;
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
        let per_launch = rays_per_launch(&ctx.limits) as u64;
        if pixels > per_launch {
            return Err(too_large(
                "primary rays",
                pixels * size_of::<GpuRay>() as u64,
                "max_storage_buffer_binding_size",
                per_launch * size_of::<GpuRay>() as u64,
            ));
        }
        // Below the binding limit's ray count, so far below 2^32.
        let n = pixels as u32;
        let samples = settings.samples;
        // Primaries per probe chunk: their probes must fit one binding.
        let chunk = if samples == 0 {
            n
        } else {
            let fit = (per_launch / u64::from(samples)).max(1);
            u32::try_from(fit.min(u64::from(n))).unwrap_or(n)
        };
        let probe_slots = u64::from(chunk) * u64::from(samples.max(1));
        check_size(ctx, "AO probes", probe_slots * size_of::<GpuRay>() as u64)?;
        let halton: Vec<[f32; 2]> = (0..samples.max(1))
            .map(|i| {
                [
                    crate::ao::radical_inverse(i + 1, 2),
                    crate::ao::radical_inverse(i + 1, 3),
                ]
            })
            .collect();
        let f = camera.frame(width, height);
        let v4 = |v: Vec3| v.extend(0.0).to_array();
        let params = Params {
            eye: v4(camera.eye),
            fwd: v4(f.forward),
            right: v4(f.right),
            up: v4(f.up),
            plane_w: f.half_width,
            plane_h: f.half_height,
            max_distance: settings
                .max_distance
                .unwrap_or(AoSettings::DISTANCE_FRACTION * self.diagonal),
            gamma8: crate::spawn::gamma(8),
            width,
            height,
            count: n,
            samples,
            base: 0,
            chunk: 0,
            // The seed's two words.
            seed_lo: settings.seed as u32,
            seed_hi: (settings.seed >> 32) as u32,
        };
        let storage = |label: &str, size: u64, usage| self.scratch(label, size, usage);
        let none = wgpu::BufferUsages::empty();
        let copy = wgpu::BufferUsages::COPY_SRC;
        let ray_bytes = size_of::<GpuRay>() as u64;
        let stage = Stage {
            n,
            chunk,
            params,
            primary: storage("cobalt primary rays", u64::from(n) * ray_bytes, copy),
            pixel_of: storage("cobalt primary pixels", u64::from(n) * 4, copy),
            hits: storage("cobalt primary hits", u64::from(n) * RESULT_BYTES, none),
            probes: storage("cobalt AO probes", probe_slots * ray_bytes, none),
            probe_hits: storage("cobalt AO probe hits", probe_slots * RESULT_BYTES, none),
            film: storage("cobalt film", u64::from(n) * 4, copy),
            halton: init(
                device,
                "cobalt Halton points",
                bytemuck::cast_slice(&halton),
                wgpu::BufferUsages::STORAGE,
            ),
        };
        let group = self.bind(&stage, &params);
        ctx.queue
            .submit([self.run(&self.raygen, &group, n).finish()]);
        Ok(stage)
    }

    /// A storage buffer of at least `size` bytes (a binding may not be empty), also usable
    /// as `usage`.
    pub(super) fn scratch(
        &self,
        label: &str,
        size: u64,
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        storage(&self.ctx.device, label, size.max(16), usage)
    }

    /// A bind group of `stage`'s buffers with `params`.
    fn bind(&self, stage: &Stage, params: &Params) -> wgpu::BindGroup {
        let device = &self.ctx.device;
        self.program.bind_params(
            device,
            "render",
            bytemuck::bytes_of(params),
            &[
                &stage.primary,
                &stage.pixel_of,
                &stage.hits,
                &self.tris,
                &stage.halton,
                &stage.probes,
                &stage.probe_hits,
                &stage.film,
            ],
        )
    }

    /// Commands running `pipeline` over `items` invocations.
    pub(super) fn run(
        &self,
        pipeline: &wgpu::ComputePipeline,
        group: &wgpu::BindGroup,
        items: u32,
    ) -> wgpu::CommandEncoder {
        let grid = grid(&self.ctx.limits, items.div_ceil(64));
        dispatch(
            &self.ctx.device,
            "cobalt render pass",
            pipeline,
            group,
            grid,
        )
    }

    /// Renders ambient occlusion as [`crate::shade::render`] does with
    /// [`crate::shade::Shader::Ao`]`(settings)`: `settings.samples` probes per primary hit.
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] when the primary rays exceed a binding (about 4 million pixels
    /// under lavapipe's 128 MiB) or a side of the image is not in 1..=65536, and the errors of
    /// a trace.
    pub fn render_ao(
        &self,
        width: u32,
        height: u32,
        camera: &Camera,
        settings: &AoSettings,
    ) -> Result<GpuRendering, GpuError> {
        let start = Instant::now();
        let stage = self.begin(width, height, camera, settings)?;
        let n = stage.n;
        let samples = settings.samples;
        let rendering = |film: Film, secondary_rays: usize, gpu: Option<f64>| GpuRendering {
            film,
            primary_rays: n as usize,
            secondary_rays,
            trace_gpu_seconds: gpu,
            seconds: start.elapsed().as_secs_f64(),
        };
        if self.scene.empty {
            // Every primary misses and sees the sky.
            let mut film = Film::new(width, height);
            for p in 0..n as usize {
                film.set(p, Vec3::ONE);
            }
            return Ok(rendering(film, 0, None));
        }
        let ctx = &self.ctx;
        let mut gpu_seconds = ctx.timestamps.then_some(0.0);
        let s = self.trace(&stage.primary, &stage.hits, n, GpuMode::Closest)?;
        gpu_seconds = gpu_seconds.zip(s).map(|(a, b)| a + b);
        let mut base = 0;
        while base < n {
            let len = stage.chunk.min(n - base);
            let group = self.bind(
                &stage,
                &Params {
                    base,
                    chunk: len,
                    ..stage.params
                },
            );
            if samples > 0 {
                ctx.queue
                    .submit([self.run(&self.shade_ao, &group, len).finish()]);
                let s = self.trace(
                    &stage.probes,
                    &stage.probe_hits,
                    len * samples,
                    GpuMode::Any,
                )?;
                gpu_seconds = gpu_seconds.zip(s).map(|(a, b)| a + b);
            }
            ctx.queue
                .submit([self.run(&self.accumulate, &group, len).finish()]);
            base += len;
        }
        let bytes = fetch(&self.ctx, &stage.film, u64::from(n) * 4)?;
        let values: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes);
        let mut film = Film::new(width, height);
        for (p, &v) in values.iter().enumerate() {
            film.set(p, Vec3::splat(v));
        }
        Ok(rendering(film, n as usize * samples as usize, gpu_seconds))
    }

    /// The primary rays `render_ao` generates on the device, read back (the CPU's
    /// [`Camera::primary_rays`], in its Morton order), with the pixel of each.
    ///
    /// # Errors
    /// As [`GpuRenderer::render_ao`].
    pub fn primary_rays(
        &self,
        width: u32,
        height: u32,
        camera: &Camera,
    ) -> Result<(Vec<GpuRay>, Vec<u32>), GpuError> {
        let stage = self.begin(width, height, camera, &AoSettings::default())?;
        let n = u64::from(stage.n);
        let rays = fetch(&self.ctx, &stage.primary, n * size_of::<GpuRay>() as u64)?;
        let pixels = fetch(&self.ctx, &stage.pixel_of, n * 4)?;
        Ok((
            bytemuck::pod_collect_to_vec(&rays),
            bytemuck::pod_collect_to_vec(&pixels),
        ))
    }
}

/// The buffers of one render, on the device.
pub(super) struct Stage {
    /// Primary rays (pixels).
    pub(super) n: u32,
    /// Primaries whose probes are traced together.
    pub(super) chunk: u32,
    pub(super) params: Params,
    pub(super) primary: wgpu::Buffer,
    pub(super) pixel_of: wgpu::Buffer,
    pub(super) hits: wgpu::Buffer,
    pub(super) probes: wgpu::Buffer,
    pub(super) probe_hits: wgpu::Buffer,
    pub(super) film: wgpu::Buffer,
    pub(super) halton: wgpu::Buffer,
}
