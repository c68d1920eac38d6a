//! Procedural scenes that need no files, deterministic for a given detail (fixed seeds).
//!
//! - `forest`: sparse geometry with a huge range of triangle sizes (large ground triangles and
//!   many small plants), the character of the Fairy Forest benchmark; ~140k triangles at 1.0.
//! - `hairball`: a dense tangle of thin tubes, ~1M triangles at 1.0.
//! - `cornell`: a Cornell box with a mirror and a diffuse sphere and a ceiling light.

mod cornell;
mod forest;
mod hairball;
pub mod mesh;

use crate::Result;
use crate::scene::{LoadReport, Material, Scene, SceneNeeds};
pub use mesh::MeshBuilder;

/// The built-in generators.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Builtin {
    /// Ground and plants with a huge range of triangle sizes.
    Forest,
    /// A dense tangle of thin tubes.
    Hairball,
    /// A Cornell box with spheres.
    Cornell,
}

impl Builtin {
    /// All of them, for listings and tests.
    pub const ALL: [Self; 3] = [Self::Forest, Self::Hairball, Self::Cornell];

    /// About how many triangles the generator makes at `detail` (measured at detail 1 and
    /// rounded up; the count grows about linearly with detail), so that what a scene needs
    /// can be checked before it is generated.
    pub fn triangles_at(self, detail: f32) -> u64 {
        let per_detail = match self {
            Self::Forest => 146_000.0,
            Self::Hairball => 1_010_000.0,
            Self::Cornell => 11_000.0,
        };
        (per_detail * f64::from(detail)).ceil() as u64
    }

    /// By the name used in `builtin:NAME`.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "forest" => Some(Self::Forest),
            "hairball" => Some(Self::Hairball),
            "cornell" => Some(Self::Cornell),
            _ => None,
        }
    }

    /// The name used in `builtin:NAME`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Forest => "forest",
            Self::Hairball => "hairball",
            Self::Cornell => "cornell",
        }
    }

    /// Generates the scene; `detail` (> 0) scales the triangle count roughly linearly.
    pub fn generate(self, detail: f32, needs: SceneNeeds) -> Result<Scene> {
        let (mesh, materials, lights) = match self {
            Self::Forest => (forest::generate(detail), forest::materials(), Vec::new()),
            Self::Hairball => (hairball::generate(detail), Vec::new(), Vec::new()),
            Self::Cornell => {
                let (m, l) = cornell::generate(detail);
                (m, cornell::materials(), l)
            }
        };
        let name = format!("builtin:{}:{detail}", self.name());
        let report = LoadReport {
            vertices: mesh.positions.len(),
            faces: mesh.triangles.len(),
            ..Default::default()
        };
        let mut scene = Scene::from_parts(name, mesh.positions, mesh.triangles, report)?;
        if needs.lights {
            scene.lights = lights;
        }
        scene.normalise();
        if needs.normals {
            scene.compute_vertex_normals();
        }
        if needs.materials {
            if materials.is_empty() {
                scene.use_default_material(Material::default());
            } else {
                scene.materials = materials;
                scene.material_ids = mesh.material_ids;
            }
        }
        if needs.lights && scene.lights.is_empty() {
            scene.add_default_light();
        }
        Ok(scene)
    }
}
