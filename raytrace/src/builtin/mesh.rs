//! A small mesh builder shared by the generators and the test kit.

use std::collections::HashMap;

use glam::{Quat, Vec3};

/// Triangles under construction, with one material id per triangle.
#[derive(Clone, Debug, Default)]
pub struct MeshBuilder {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Material of each triangle.
    pub material_ids: Vec<u32>,
}

impl MeshBuilder {
    /// Adds a vertex, returning its index.
    pub fn vertex(&mut self, p: Vec3) -> u32 {
        self.positions.push(p);
        (self.positions.len() - 1) as u32
    }

    /// Adds a triangle of existing vertices.
    pub fn tri(&mut self, t: [u32; 3], material: u32) {
        self.triangles.push(t);
        self.material_ids.push(material);
    }

    /// Adds a triangle of new vertices.
    pub fn tri_points(&mut self, a: Vec3, b: Vec3, c: Vec3, material: u32) {
        let i = [self.vertex(a), self.vertex(b), self.vertex(c)];
        self.tri(i, material);
    }

    /// Adds a quad `a b c d` (counter-clockwise) as the fan `a b c`, `a c d`.
    pub fn quad(&mut self, q: [Vec3; 4], material: u32) {
        let i = q.map(|p| self.vertex(p));
        self.tri([i[0], i[1], i[2]], material);
        self.tri([i[0], i[2], i[3]], material);
    }

    /// Adds an `n x n` grid of quads spanning `origin + s*u + t*v`, `s, t` in `[0, 1]`, with
    /// shared vertices.
    pub fn grid(&mut self, origin: Vec3, u: Vec3, v: Vec3, n: u32, material: u32) {
        let base = self.positions.len() as u32;
        for j in 0..=n {
            for i in 0..=n {
                let p = origin + u * (i as f32 / n as f32) + v * (j as f32 / n as f32);
                self.vertex(p);
            }
        }
        let at = |i: u32, j: u32| base + j * (n + 1) + i;
        for j in 0..n {
            for i in 0..n {
                self.tri([at(i, j), at(i + 1, j), at(i + 1, j + 1)], material);
                self.tri([at(i, j), at(i + 1, j + 1), at(i, j + 1)], material);
            }
        }
    }

    /// Adds a closed icosphere (shared vertices, so it is watertight) subdivided `level` times:
    /// `20 * 4^level` triangles, outward-facing.
    pub fn icosphere(&mut self, center: Vec3, radius: f32, level: u32, material: u32) {
        let (verts, tris) = icosphere(level);
        let base = self.positions.len() as u32;
        self.positions
            .extend(verts.iter().map(|&p| center + radius * p));
        for t in tris {
            self.tri(t.map(|k| k + base), material);
        }
    }

    /// Adds an open tube of `sides` sides around the polyline `path`, with radius `r`; frames
    /// are parallel-transported so the tube does not twist.
    pub fn tube(&mut self, path: &[Vec3], r: f32, sides: u32, material: u32) {
        if path.len() < 2 || sides < 3 {
            return;
        }
        let mut tangent = (path[1] - path[0]).normalize_or(Vec3::Y);
        let mut normal = tangent.any_orthonormal_vector();
        let base = self.positions.len() as u32;
        for (k, &p) in path.iter().enumerate() {
            let next = if k + 1 < path.len() {
                (path[k + 1] - p).normalize_or(tangent)
            } else {
                tangent
            };
            let rot = Quat::from_rotation_arc(tangent, next);
            normal = rot * normal;
            tangent = next;
            let binormal = tangent.cross(normal);
            for s in 0..sides {
                let a = s as f32 / sides as f32 * std::f32::consts::TAU;
                self.vertex(p + r * (a.cos() * normal + a.sin() * binormal));
            }
        }
        for k in 0..path.len() as u32 - 1 {
            for s in 0..sides {
                let s1 = (s + 1) % sides;
                let a = base + k * sides + s;
                let b = base + k * sides + s1;
                let c = base + (k + 1) * sides + s1;
                let d = base + (k + 1) * sides + s;
                self.tri([a, b, c], material);
                self.tri([a, c, d], material);
            }
        }
    }

    /// Appends another mesh.
    pub fn append(&mut self, o: MeshBuilder) {
        let base = self.positions.len() as u32;
        self.positions.extend(o.positions);
        self.triangles
            .extend(o.triangles.into_iter().map(|t| t.map(|k| k + base)));
        self.material_ids.extend(o.material_ids);
    }
}

/// Unit icosphere: vertices on the unit sphere and outward-facing triangles, `20 * 4^level`.
pub fn icosphere(level: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut cache: HashMap<(u32, u32), u32> = HashMap::new();
        let mut mid = |a: u32, b: u32, v: &mut Vec<Vec3>| {
            let key = (a.min(b), a.max(b));
            *cache.entry(key).or_insert_with(|| {
                v.push(((v[a as usize] + v[b as usize]) * 0.5).normalize());
                (v.len() - 1) as u32
            })
        };
        let mut g = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let ab = mid(a, b, &mut v);
            let bc = mid(b, c, &mut v);
            let ca = mid(c, a, &mut v);
            g.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = g;
    }
    (v, f)
}
