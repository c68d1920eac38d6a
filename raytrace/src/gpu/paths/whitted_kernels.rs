//! The Whitted kernels (`whitted.wgsl`) and the scene's shading data on the device: materials
//! and vertex normals by primitive, and the lights. A renderer holds them from its start, so
//! they sit below both the renderer (`render.rs`) and its Whitted launches (`whitted.rs`).

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::shading::with_shading;
use crate::gpu::GpuError;
use crate::gpu::buffers::{check_size, init};
use crate::gpu::context::GpuContext;
use crate::gpu::program::{Program, READ, UNIFORM, WRITE};
use crate::scene::{Light, Scene};

/// `struct PrimShading`: material and vertex normals of one primitive.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct PrimShading {
    diffuse: [f32; 4],
    emission: [f32; 4],
    normals: [[f32; 4]; 3],
}

/// The Whitted kernels and the scene's shading data on the device.
#[derive(Debug)]
pub(super) struct WhittedKernels {
    pub(super) program: Program,
    pub(super) start: wgpu::ComputePipeline,
    pub(super) shade: wgpu::ComputePipeline,
    pub(super) shadows: wgpu::ComputePipeline,
    /// Materials and normals by primitive, or why they do not fit one binding (an AO render
    /// does not need them, so only a Whitted render fails).
    pub(super) prims: Result<wgpu::Buffer, GpuError>,
    pub(super) lights: wgpu::Buffer,
    pub(super) light_count: u32,
    pub(super) has_normals: bool,
}

impl WhittedKernels {
    /// Compiles the kernels and uploads `scene`'s materials, normals and lights.
    pub(super) fn new(ctx: &GpuContext, scene: &Scene) -> Self {
        let device = &ctx.device;
        let v4 = |v: Vec3, w: f32| v.extend(w).to_array();
        let mut prims: Vec<PrimShading> = (0..scene.len())
            .map(|prim| {
                let m = scene
                    .material_ids
                    .get(prim)
                    .and_then(|&m| scene.materials.get(m as usize))
                    .copied()
                    .unwrap_or_default();
                let normals = match &scene.normals {
                    Some(n) => scene.triangles[prim].map(|k| v4(n[k as usize], 0.0)),
                    None => [[0.0; 4]; 3],
                };
                PrimShading {
                    diffuse: v4(m.diffuse, m.reflectance),
                    emission: v4(m.emission, 0.0),
                    normals,
                }
            })
            .collect();
        if prims.is_empty() {
            // A binding may not be empty; nothing reads it when nothing is hit.
            prims.push(PrimShading::default());
        }
        let mut lights: Vec<[[f32; 4]; 2]> = scene
            .lights
            .iter()
            .map(
                |Light::Point {
                     position,
                     intensity,
                 }| [v4(*position, 0.0), v4(*intensity, 0.0)],
            )
            .collect();
        let light_count = u32::try_from(lights.len()).unwrap_or(u32::MAX);
        if lights.is_empty() {
            lights.push([[0.0; 4]; 2]);
        }
        let prim_bytes: &[u8] = bytemuck::cast_slice(&prims);
        let init = |label: &str, contents: &[u8]| {
            init(device, label, contents, wgpu::BufferUsages::STORAGE)
        };
        let program = Program::new(
            device,
            "whitted",
            with_shading(include_str!("whitted.wgsl")),
            &[
                UNIFORM, READ, READ, READ, READ, READ, WRITE, READ, WRITE, WRITE, WRITE, READ,
                WRITE,
            ],
        );
        let make = |entry: &str, label: &str| program.pipeline(device, entry, label);
        Self {
            start: make("start", "cobalt Whitted path start pipeline"),
            shade: make("shade", "cobalt Whitted shading pipeline"),
            shadows: make("shadows", "cobalt Whitted shadows pipeline"),
            program,
            prims: check_size(ctx, "materials and normals", prim_bytes.len() as u64)
                .map(|()| init("cobalt materials and normals", prim_bytes)),
            lights: init("cobalt lights", bytemuck::cast_slice(&lights)),
            light_count,
            has_normals: scene.normals.is_some(),
        }
    }
}
