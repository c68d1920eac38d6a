//! Shading as generations of ray batches: a shader turns hits
//! into the next batch of rays (shadow, reflection or AO probes) or into pixels, and every
//! batch is traced through one [`Tracer`], the seam where a scheduler will cut generations
//! into tasks and spread them over devices.
//!
//! ```
//! use raytrace::shade::{CpuTracer, RenderOptions, Shader, render};
//! use raytrace::{BuildPreset, Bvh, Camera, SceneSource};
//!
//! let shader = Shader::Whitted(Default::default());
//! let scene = SceneSource::parse("builtin:cornell:0.2")?.load(shader.needs())?;
//! let bvh = Bvh::build(&scene, BuildPreset::Medium)?;
//! let options = RenderOptions::new(16, 16, Camera::orbit(&scene.bounds(), 0), shader);
//! let image = render(&scene, &mut CpuTracer::new(&bvh), &options);
//! assert_eq!(image.generations[0].rays, 256);
//! # Ok::<(), raytrace::Error>(())
//! ```

mod ao;
mod generation;
mod surface;
mod tracer;
mod whitted;

use std::time::Instant;

pub use ao::AoSettings;
pub use generation::Generation;
pub use tracer::{CpuTracer, Recorder, Tracer};
pub use whitted::{AMBIENT, SKY, WhittedSettings};

use crate::cost::SampleRate;
use crate::{Camera, Film, Scene, SceneNeeds};
use generation::Generations;

/// Which shader, with its settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shader {
    /// Ambient occlusion: the diffuse workload.
    Ao(AoSettings),
    /// Whitted: the coherent workload.
    Whitted(WhittedSettings),
}

impl Shader {
    /// The share of each task's paths an estimate samples unless told otherwise: one in 64
    /// for Whitted's coherent paths, whose sample is rendered in full (every shadow ray and
    /// bounce) and whose neighbours cost alike; one in 32 for ambient occlusion, whose sample
    /// keeps only its share of each path's probes and so costs little, and whose tasks differ
    /// more (`docs/results.md`, "What an estimate costs").
    pub fn sample_rate(&self) -> SampleRate {
        match self {
            Self::Ao(_) => SampleRate::ONE_IN_32,
            Self::Whitted(_) => SampleRate::ONE_IN_64,
        }
    }

    /// What the scene must keep for this shader.
    pub fn needs(&self) -> SceneNeeds {
        match self {
            Self::Ao(_) => SceneNeeds::AO,
            Self::Whitted(_) => SceneNeeds::WHITTED,
        }
    }

    /// The AO probe length in `scene`'s units ([`AoSettings::distance`]); 0 for Whitted.
    pub fn ao_distance(&self, scene: &Scene) -> f32 {
        match self {
            Self::Ao(s) => s.distance(scene),
            Self::Whitted(_) => 0.0,
        }
    }

    /// `ao` or `whitted`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Ao(_) => "ao",
            Self::Whitted(_) => "whitted",
        }
    }
}

/// What to render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The camera.
    pub camera: Camera,
    /// The shader.
    pub shader: Shader,
}

impl RenderOptions {
    /// A `width × height` image of `shader` seen from `camera`.
    pub fn new(width: u32, height: u32, camera: Camera, shader: Shader) -> Self {
        Self {
            width,
            height,
            camera,
            shader,
        }
    }
}

/// A finished render.
#[derive(Clone, Debug)]
pub struct Rendering {
    /// The image (linear; encode with [`crate::film::ToneMap::Srgb`]).
    pub film: Film,
    /// Every traced generation, in order.
    pub generations: Vec<Generation>,
    /// Wall time of the whole render (ray generation, tracing and shading).
    pub seconds: f64,
}

impl Rendering {
    /// Rays traced over all generations.
    pub fn total_rays(&self) -> usize {
        self.generations.iter().map(|g| g.rays).sum()
    }

    /// Time spent tracing, over all generations.
    pub fn trace_seconds(&self) -> f64 {
        self.generations.iter().map(|g| g.seconds).sum()
    }

    /// Rendering efficiency as the thesis defines it: all rays over the render's wall time.
    pub fn mrays_per_s(&self) -> f64 {
        self.total_rays() as f64 / self.seconds.max(1e-12) / 1e6
    }
}

/// Renders `scene` as `options` say, tracing every generation through `tracer`.
///
/// A scene loaded without materials shades with [`crate::Material::default`]; one without
/// normals shades with geometric normals; lights are the scene's (loading with
/// [`Shader::needs`] adds the default light where a scene has none).
///
/// # Panics
/// Panics if a side of the image exceeds 65536 pixels.
pub fn render<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &mut T,
    options: &RenderOptions,
) -> Rendering {
    let (w, h) = (options.width, options.height);
    let start = Instant::now();
    let primary = options.camera.primary_rays(w, h);
    let mut film = Film::new(w, h);
    let distance = options.shader.ao_distance(scene);
    let generations = shade(
        scene,
        tracer,
        options.shader,
        (primary, &mut film),
        distance,
        None,
    );
    Rendering {
        film,
        generations,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// Shades `primary` into `film` with `shader` (AO probes `ao_distance` long), tracing through
/// `tracer`; `ranks` are the paths' Morton ranks where `primary` holds paths, not the image.
/// Returns every generation traced.
fn shade<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &mut T,
    shader: Shader,
    (primary, film): (crate::PrimaryRays, &mut Film),
    ao_distance: f32,
    ranks: Option<&[u32]>,
) -> Vec<Generation> {
    let mut gens = Generations::new(tracer);
    match shader {
        Shader::Ao(s) => ao::render(scene, &mut gens, primary, film, (s, ao_distance), ranks),
        Shader::Whitted(s) => whitted::render(scene, &mut gens, primary, film, s),
    }
    gens.log
}

/// What [`render_paths`] made: one value per path, and the generations it traced.
#[derive(Clone, Debug, Default)]
pub struct PathRendering {
    /// Each path's radiance (grey for ambient occlusion), in the order of the ranks given.
    pub values: Vec<glam::Vec3>,
    /// Every traced generation, in order.
    pub generations: Vec<Generation>,
}

/// Renders the paths `ranks` (indices into the image's Morton order) of `options`' image,
/// tracing through `tracer`: each path's value is the one [`render`] gives its pixel, bit for
/// bit, whatever other paths are rendered with it. Shading runs in the caller's rayon pool.
///
/// # Panics
/// Panics if a side of the image exceeds 65536 pixels or a rank is outside the image.
pub fn render_paths<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &mut T,
    options: &RenderOptions,
    ranks: &[u32],
) -> PathRendering {
    render_paths_at(
        scene,
        tracer,
        options,
        ranks,
        options.shader.ao_distance(scene),
    )
}

/// [`render_paths`] with the AO probe length already resolved ([`Shader::ao_distance`]):
/// finding it reads every vertex, which costs more than the few paths of a task's sample.
pub(crate) fn render_paths_at<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &mut T,
    options: &RenderOptions,
    ranks: &[u32],
    ao_distance: f32,
) -> PathRendering {
    let (w, h) = (options.width, options.height);
    let mut primary = options
        .camera
        .primary_rays_of(w, h, ranks.iter().map(|&r| r as usize));
    // Shading writes each path's value at its place in `ranks`, into a film of one row.
    primary.pixels = (0..ranks.len() as u32).collect();
    let mut film = Film::new(ranks.len().max(1) as u32, 1);
    let film_of = (primary, &mut film);
    let generations = shade(
        scene,
        tracer,
        options.shader,
        film_of,
        ao_distance,
        Some(ranks),
    );
    let mut values = film.pixels().to_vec();
    values.truncate(ranks.len());
    PathRendering {
        values,
        generations,
    }
}
