//! Whitted shading on the GPU, and the render of either shader ([`GpuRenderer::render`]): a
//! Whitted launch's primary rays
//! from the path kernels' `raygen`, then per bounce a closest-hit trace, `whitted.wgsl`'s
//! `shade` (emission, ambient, one shadow ray per light, the mirror ray), an any-hit trace of
//! the shadow rays and `shadows` (their light); every buffer stays on the device until the
//! paths' values are read back.
//!
//! Every path keeps its slot through the bounces (a finished one traces an empty-range ray),
//! so nothing is compacted between generations; the values are [`crate::shade::render`]'s
//! with [`crate::shade::Shader::Whitted`] up to the differences `shading.wgsl` lists.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::render::{GpuRenderer, Stage, Tally};
use crate::gpu::GpuError;
use crate::gpu::buffers::{GpuRay, RESULT_BYTES, check_size};
use crate::gpu::header::Header;
use crate::gpu::launch::{Count, Recorder};
use crate::gpu::trace::{ANY, CLOSEST};
use crate::paths::Launch;
use crate::shade::{AMBIENT, AoSettings, RenderOptions, SKY, Shader, WhittedSettings};
use crate::traffic::Traffic;

/// Bytes of a path's value in `whitted.wgsl`'s film, read back: red, green and blue words.
const FILM_BYTES: u64 = 12;

/// `whitted.wgsl`'s `struct Params`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct Params {
    sky: [f32; 4],
    count: u32,
    lights: u32,
    bounce: u32,
    bounces: u32,
    gamma8: f32,
    ambient: f32,
    shadow_tmax: f32,
    has_normals: u32,
}

const _: () = assert!(size_of::<Params>() == 48);

/// Byte offset of `count` in [`Params`], copied in from the launch's header.
const COUNT_AT: u64 = 16;

impl GpuRenderer {
    /// Renders the paths of `tasks` (ranges of paths in `frame`'s Morton order) as
    /// [`crate::shade::render`] does with `frame`, with the materials, normals and lights of
    /// the scene this renderer was made with. The launch's rays are the primary rays, then
    /// `samples` AO probes per primary ray, or per bounce one shadow ray per light and one
    /// mirror ray per path (slots of paths that ended hold empty-range rays, which end at
    /// once and add nothing); its device seconds are its kernels' time from timestamp
    /// queries, where the device has them.
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] when the launch's primary rays exceed a binding (about 4
    /// million under lavapipe's 128 MiB), or with Whitted shading its shadow rays (one per
    /// path and light) or the scene's materials and normals do, a side of the image is not in
    /// 1..=65536 or a task reaches past the image, and the errors of a trace.
    pub fn render(
        &self,
        frame: &RenderOptions,
        tasks: &[&Range<usize>],
    ) -> Result<Launch, GpuError> {
        match frame.shader {
            Shader::Ao(s) => self.render_ao(frame, tasks, &s),
            Shader::Whitted(s) => self.render_whitted(frame, tasks, &s),
        }
    }

    /// The paths of `tasks` with Whitted shading (see [`GpuRenderer::render`]).
    fn render_whitted(
        &self,
        frame: &RenderOptions,
        tasks: &[&Range<usize>],
        settings: &WhittedSettings,
    ) -> Result<Launch, GpuError> {
        // No probes: the stage's probe buffer (one ray per path) holds the mirror rays.
        let no_probes = AoSettings {
            samples: 0,
            ..AoSettings::default()
        };
        let rgb: fn(&[u8]) -> Vec3 = |c| Vec3::from_array(bytemuck::pod_read_unaligned(c));
        let lights = self.whitted.light_count;
        self.drained(|checked| {
            let values = (SKY, FILM_BYTES, rgb);
            self.launch(
                frame,
                tasks,
                (&no_probes, lights),
                checked,
                values,
                |l, s, g, t| self.record_whitted(l, s, g, settings, None, t),
            )
        })
    }

    /// Records a Whitted launch of `stage` (`raygen`: the bind group of its primaries) into
    /// `launch`: raygen, then per bounce the trace, shading, shadow rays and their light.
    /// Returns the buffer of the paths' values and the rays traced. With `tally`, every
    /// trace adds its rays' counts to their paths' entries of `tally.paths` (an estimate's
    /// launch).
    pub(in crate::gpu) fn record_whitted(
        &self,
        launch: &mut Recorder<'_>,
        stage: &Stage,
        raygen: &wgpu::BindGroup,
        settings: &WhittedSettings,
        tally: Option<&Tally>,
        traffic: &mut Traffic,
    ) -> Result<(wgpu::Buffer, usize), GpuError> {
        let n = stage.n;
        let lights = self.whitted.light_count;
        let ctx = &self.dev.ctx;
        let device = &ctx.device;
        let w = &self.whitted;
        let prims = w.prims.as_ref().map_err(Clone::clone)?;
        let slots = u64::from(n) * u64::from(lights);
        let ray_bytes = size_of::<GpuRay>() as u64;
        check_size(ctx, "shadow rays", slots * ray_bytes)?;
        let storage = |label: &'static str, size: u64, usage| self.scratch(label, size, usage);
        let none = wgpu::BufferUsages::empty();
        // Every path starts alive with weight 1; a kernel sets them, so nothing is uploaded.
        let paths = storage("cobalt Whitted paths", u64::from(n) * 16, none);
        let film = storage(
            "cobalt Whitted path values",
            u64::from(n) * FILM_BYTES,
            wgpu::BufferUsages::COPY_SRC,
        );
        let shadow_rays = storage("cobalt shadow rays", slots * ray_bytes, none);
        let shadow_light = storage("cobalt shadow light", slots * 16, none);
        let shadow_hits = storage("cobalt shadow hits", slots * RESULT_BYTES, none);
        // The launch's count is copied in on the device: these blocks stay across launches.
        let base = Params {
            sky: SKY.extend(0.0).to_array(),
            count: 0,
            lights,
            bounce: 0,
            bounces: settings.bounces,
            gamma8: crate::spawn::gamma(8),
            ambient: AMBIENT,
            shadow_tmax: 1.0 - 1e-4,
            has_normals: u32::from(w.has_normals),
        };
        let mut uniforms = Vec::new();
        let mut bind = |params: &Params, rays: &wgpu::Buffer, next: &wgpu::Buffer| {
            let key = ("cobalt Whitted parameters", params.bounce);
            let uniform = self
                .resident
                .uniform(ctx, key, bytemuck::bytes_of(params), traffic);
            uniforms.push(uniform.clone());
            w.program.bind(
                device,
                "cobalt Whitted bind group",
                &[
                    &uniform,
                    rays,
                    &stage.hits,
                    &self.tris,
                    prims,
                    &w.lights,
                    &paths,
                    &stage.ranks,
                    &film,
                    &shadow_rays,
                    &shadow_light,
                    &shadow_hits,
                    next,
                ],
            )
        };
        let mut groups = Vec::new();
        let (mut rays, mut next) = (&stage.primary, &stage.probes);
        for bounce in 0..=settings.bounces {
            groups.push(bind(&Params { bounce, ..base }, rays, next));
            std::mem::swap(&mut rays, &mut next);
        }
        let header = &stage.header;
        for uniform in &uniforms {
            launch.copy(header, Header::COUNT, uniform, COUNT_AT, 4);
        }
        launch.pass_over(&self.raygen, raygen, n);
        // Bounce 0's group starts the paths: the same buffers and parameters.
        launch.pass_over(&w.start, &groups[0], n);
        let mut traced = 0usize;
        let (mut rays, mut next) = (&stage.primary, &stage.probes);
        for group in &groups {
            let count = match tally {
                Some(t) => Count::Counted {
                    counts: &t.paths,
                    per_path: 1,
                },
                None => Count::Copied(header, Header::COUNT),
            };
            launch.trace(rays, &stage.hits, n, CLOSEST, count, traffic)?;
            launch.pass_over(&w.shade, group, n);
            if lights > 0 {
                // `slots` fits one binding, so far below 2^32.
                launch.trace(
                    &shadow_rays,
                    &shadow_hits,
                    slots as u32,
                    ANY,
                    match tally {
                        Some(t) => Count::Counted {
                            counts: &t.paths,
                            per_path: lights,
                        },
                        None => Count::Copied(header, Header::SECONDARY),
                    },
                    traffic,
                )?;
                launch.pass_over(&w.shadows, group, n);
            }
            traced += n as usize + slots as usize;
            std::mem::swap(&mut rays, &mut next);
        }
        Ok((film, traced))
    }
}
