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

/// A scene file as its format's loader read it, before [`Scene::from_file`] makes it a scene
/// the same way for every format.
#[derive(Debug, Default)]
pub(crate) struct FileMesh {
    /// Vertex positions, in the file's units.
    pub positions: Vec<Vec3>,
    /// Vertex indices of each triangle, in file order.
    pub triangles: Vec<[u32; 3]>,
    /// One shading normal per vertex, where the file gives every vertex one.
    pub normals: Option<Vec<Vec3>>,
    /// The file's materials; the default material goes before them as material 0.
    pub materials: Vec<Material>,
    /// Each triangle's material (0 the default, `k` the file's `k - 1`th); empty where the
    /// format has no materials.
    pub material_ids: Vec<u32>,
    /// What the file held (vertices, faces) and any warnings.
    pub report: LoadReport,
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
    /// The power of two between the source's coordinates and these: a point `p` of the file
    /// (or generator) is `p · 2^-unit` here (see [`Scene::normalise`]); 0 for a scene built
    /// from parts.
    pub unit: i32,
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
            unit: 0,
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

    /// The scene of a file, whatever its format: checked as [`Scene::from_parts`], brought into
    /// range ([`Scene::normalise`]), and given what `needs` asks for: the file's normals where
    /// every vertex has one (else computed), its materials after the default, the default light.
    pub(crate) fn from_file(name: String, mesh: FileMesh, needs: SceneNeeds) -> Result<Self> {
        let mut scene = Self::from_parts(name, mesh.positions, mesh.triangles, mesh.report)?;
        scene.normalise();
        if needs.normals {
            match mesh.normals {
                Some(n) if n.len() == scene.positions.len() => scene.normals = Some(n),
                _ => scene.compute_vertex_normals(),
            }
        }
        if needs.materials {
            scene.materials = std::iter::once(Material::default())
                .chain(mesh.materials)
                .collect();
            scene.material_ids = if mesh.material_ids.len() == scene.triangles.len() {
                mesh.material_ids
            } else {
                vec![0; scene.triangles.len()]
            };
        }
        if needs.lights {
            scene.add_default_light();
        }
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

    /// Divides every coordinate by the power of two that brings the largest coordinate
    /// magnitude into `[1, 2)`, and records it in [`Scene::unit`]; lights given so far move
    /// with the geometry. Loaders call it before they add normals or lights.
    ///
    /// Why: a power-of-two scale changes no rounding, so every product and sum the renderer
    /// computes scales exactly, and the scene renders the same image in any units. Without
    /// it, the watertight test's products (up to three coordinates deep) and a normal's
    /// squared length overflow `f32` for scenes measured in the millions of units and
    /// underflow for scenes in the millionths, and the image fills with self-shadowing
    /// speckle or goes blank.
    pub fn normalise(&mut self) {
        let largest = self
            .positions
            .iter()
            .map(|p| p.abs().max_element())
            .fold(0.0f32, f32::max);
        if !(largest > 0.0 && largest.is_finite()) {
            return;
        }
        // `floor(log2)` is exact in f64 for every f32 (a power of two's log is an integer,
        // and the next float below one is far from it).
        let unit = f64::from(largest).log2().floor() as i32;
        self.unit += unit;
        let scale = pow2(-unit);
        for p in &mut self.positions {
            *p = scaled(*p, scale);
        }
        for light in &mut self.lights {
            let Light::Point {
                position,
                intensity,
            } = light;
            *position = scaled(*position, scale);
            // Light falls off with distance squared.
            *intensity = scaled(*intensity, scale * scale);
        }
    }

    /// A point given in the source's units (a camera's eye, say) in the scene's.
    pub fn to_scene(&self, p: Vec3) -> Vec3 {
        scaled(p, pow2(-self.unit))
    }

    /// A point of the scene in the source's units (for reports).
    pub fn to_source(&self, p: Vec3) -> Vec3 {
        scaled(p, pow2(self.unit))
    }

    /// Rays given in the source's units (a ray file) in the scene's: origins and directions
    /// scale alike, so every ray keeps its `t` range and finds its hits at the same `t`.
    pub fn rays_to_scene(&self, rays: &mut crate::RayBatch) {
        let scale = pow2(-self.unit);
        for axis in [
            &mut rays.ox,
            &mut rays.oy,
            &mut rays.oz,
            &mut rays.dx,
            &mut rays.dy,
            &mut rays.dz,
        ] {
            for v in axis.iter_mut() {
                *v = (f64::from(*v) * scale) as f32;
            }
        }
    }

    /// A length of the scene in the source's units (for reports).
    pub fn length_to_source(&self, d: f32) -> f32 {
        scaled_length(d, self.unit)
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

/// `2^e` as an `f64`: exact for every exponent a scene can need.
fn pow2(e: i32) -> f64 {
    2f64.powi(e)
}

/// `d · 2^e`, exact wherever the result is an `f32`.
pub(crate) fn scaled_length(d: f32, e: i32) -> f32 {
    (f64::from(d) * pow2(e)) as f32
}

/// `v · scale`, computed in `f64` so that a scale beyond `f32`'s range still gives the exact
/// product wherever that product is an `f32`.
fn scaled(v: Vec3, scale: f64) -> Vec3 {
    (v.as_dvec3() * scale).as_vec3()
}
