//! Scenes: triangles (always), and normals, materials and lights only when the shader needs them.

use std::path::PathBuf;

use glam::Vec3;

use crate::{Aabb, Error, Result};

/// Mirror reflectance of the default material, given to scenes without materials.
pub const DEFAULT_REFLECTANCE: f32 = 0.3;

/// What a shader will read, so a scene keeps nothing else (ambient occlusion needs only
/// positions and indices; Whitted needs materials and lights, and normals to shade smoothly).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneNeeds {
    /// Per-vertex shading normals (from the file, else computed).
    pub normals: bool,
    /// Per-triangle materials (from MTL, else the default).
    pub materials: bool,
    /// Lights (from the scene, else one default point light).
    pub lights: bool,
}

impl SceneNeeds {
    /// Geometry only: what ambient occlusion and `cobalt trace` need.
    pub const AO: Self = Self {
        normals: false,
        materials: false,
        lights: false,
    };
    /// Everything Whitted shading reads.
    pub const WHITTED: Self = Self {
        normals: true,
        materials: true,
        lights: true,
    };
}

/// A surface: diffuse colour, mirror reflectance (drives reflection rays) and emission.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Diffuse albedo.
    pub diffuse: Vec3,
    /// Fraction of light mirrored; zero means no reflection ray is spawned.
    pub reflectance: f32,
    /// Emitted radiance (light sources drawn as geometry).
    pub emission: Vec3,
}

impl Default for Material {
    /// Grey, with [`DEFAULT_REFLECTANCE`] so Whitted spawns reflection rays as in the thesis.
    fn default() -> Self {
        Self {
            diffuse: Vec3::splat(0.7),
            reflectance: DEFAULT_REFLECTANCE,
            emission: Vec3::ZERO,
        }
    }
}

impl Material {
    /// From an MTL entry: `Kd` is the diffuse colour, the mean of `Ks` the mirror reflectance
    /// when `illum` asks for reflection (3 and up), `Ke` the emission.
    pub fn from_mtl(m: &tobj::Material) -> Self {
        let v = |a: Option<[f32; 3]>| a.map(Vec3::from);
        let reflects = m.illumination_model.is_some_and(|i| i >= 3);
        let ks = v(m.specular).unwrap_or(Vec3::ZERO);
        let ke = m
            .unknown_param
            .get("Ke")
            .and_then(|s| {
                let f: Vec<f32> = s
                    .split_whitespace()
                    .filter_map(|w| w.parse().ok())
                    .collect();
                (f.len() == 3).then(|| Vec3::new(f[0], f[1], f[2]))
            })
            .or(v(m.emissive))
            .unwrap_or(Vec3::ZERO);
        Self {
            diffuse: v(m.diffuse).unwrap_or(Vec3::splat(0.7)),
            reflectance: if reflects {
                ((ks.x + ks.y + ks.z) / 3.0).clamp(0.0, 1.0)
            } else {
                0.0
            },
            emission: ke,
        }
    }
}

/// A light for shadow rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// A point light: position and radiant intensity.
    Point {
        /// Where it is.
        position: Vec3,
        /// Intensity (per colour channel).
        intensity: Vec3,
    },
}

/// What loading found, printed by the CLI and kept in reports.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadReport {
    /// Vertices in the file (or generated).
    pub vertices: usize,
    /// Polygons in the file (or generated).
    pub faces: usize,
    /// Triangles after fan triangulation: the size of the primitive id space.
    pub triangles: usize,
    /// Triangles of zero area: they keep their ids but are left out of the BVH.
    pub degenerate: usize,
    /// Time to load or generate.
    pub seconds: f64,
    /// Things worth telling the user that did not stop the load (e.g. a missing MTL file).
    pub warnings: Vec<String>,
}

/// A triangle scene. Primitive id `i` is `triangles[i]`, in file order.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The file path or `builtin:NAME:detail`.
    pub name: String,
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Vertex indices of each triangle.
    pub triangles: Vec<[u32; 3]>,
    /// Per-vertex shading normals, when asked for.
    pub normals: Option<Vec<Vec3>>,
    /// Materials (index 0 is the default) when asked for, else empty.
    pub materials: Vec<Material>,
    /// Material of each triangle when materials were asked for, else empty.
    pub material_ids: Vec<u32>,
    /// Lights when asked for, else empty.
    pub lights: Vec<Light>,
    /// What loading found.
    pub report: LoadReport,
}

impl Scene {
    /// A geometry-only scene from raw arrays, checked: indices in range, coordinates finite,
    /// at least one triangle. Degenerate triangles are counted into the report.
    pub fn from_parts(
        name: String,
        positions: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        mut report: LoadReport,
    ) -> Result<Self> {
        if triangles.is_empty() {
            return Err(Error::EmptyScene { name });
        }
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(Error::Parse {
                path: PathBuf::from(&name),
                line: 0,
                what: format!("vertex {i} is not finite"),
            });
        }
        let n = positions.len();
        if let Some((i, t)) = triangles
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|&k| k as usize >= n))
        {
            return Err(Error::Parse {
                path: PathBuf::from(&name),
                line: 0,
                what: format!("triangle {i} has a vertex index in {t:?} beyond {n} vertices"),
            });
        }
        let mut scene = Self {
            name,
            positions,
            triangles,
            normals: None,
            materials: Vec::new(),
            material_ids: Vec::new(),
            lights: Vec::new(),
            report: LoadReport::default(),
        };
        report.triangles = scene.triangles.len();
        report.degenerate = (0..scene.triangles.len())
            .filter(|&i| scene.is_degenerate(i))
            .count();
        if report.vertices == 0 {
            report.vertices = scene.positions.len();
        }
        scene.report = report;
        Ok(scene)
    }

    /// The three corners of triangle `prim`.
    #[inline]
    pub fn vertices(&self, prim: usize) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[prim];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// True when the triangle has zero area (computed exactly enough in f64): no ray can hit
    /// it, so the BVH leaves it out.
    pub fn is_degenerate(&self, prim: usize) -> bool {
        let [a, b, c] = self.vertices(prim).map(|v| v.as_dvec3());
        (b - a).cross(c - a) == glam::DVec3::ZERO
    }

    /// Number of triangles (the id space).
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// True when there are no triangles (never for a loaded scene).
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Bounding box of all vertices used by triangles.
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(self.positions.iter().copied())
    }

    /// Unnormalised geometric normal `(v1 - v0) x (v2 - v0)` of a triangle.
    pub fn geometric_normal(&self, prim: usize) -> Vec3 {
        let [a, b, c] = self.vertices(prim);
        (b - a).cross(c - a)
    }

    /// Area-weighted vertex normals, for files (and generators) that have none.
    pub fn compute_vertex_normals(&mut self) {
        let mut n = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.triangles {
            let [a, b, c] = t.map(|k| self.positions[k as usize]);
            let g = (b - a).cross(c - a);
            for &k in t {
                n[k as usize] += g;
            }
        }
        for v in &mut n {
            *v = v.normalize_or(Vec3::Y);
        }
        self.normals = Some(n);
    }

    /// Gives every triangle the default material (for scenes without materials).
    pub fn use_default_material(&mut self, material: Material) {
        self.materials = vec![material];
        self.material_ids = vec![0; self.triangles.len()];
    }

    /// Adds the default light: a white point light above the centre of the bounding box, 90 %
    /// of the way from the centre to the top (just below it, so closed rooms stay lit).
    pub fn add_default_light(&mut self) {
        let b = self.bounds();
        let c = b.center();
        let position = Vec3::new(c.x, c.y + 0.45 * b.extent().y, c.z);
        let d = b.extent().length().max(f32::MIN_POSITIVE);
        self.lights.push(Light::Point {
            position,
            // Falls off with distance squared: scale so the scene's extent is lit about 1.
            intensity: Vec3::splat(0.25 * d * d),
        });
    }

    /// Replaces the lights (the override of the default light).
    pub fn set_lights(&mut self, lights: Vec<Light>) {
        self.lights = lights;
    }
}
