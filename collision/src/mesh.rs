use std::path::Path;

use parry3d::math::Vector;
use parry3d::shape::TriMesh;

use crate::CollisionError;

/// A rolling terrain over the unit square, `side`×`side` quads (two triangles each) at
/// heights between about 0.07 and 0.23: the static ground the bodies fall on.
pub fn terrain(side: usize) -> Result<TriMesh, CollisionError> {
    let side = side.max(1);
    let s1 = side + 1;
    let vertices: Vec<Vector> = (0..s1 * s1)
        .map(|i| {
            let (x, y) = ((i % s1) as f32 / side as f32, (i / s1) as f32 / side as f32);
            Vector::new(x, y, 0.15 + 0.08 * (6.0 * x).sin() * (5.0 * y).cos())
        })
        .collect();
    let mut indices = Vec::with_capacity(2 * side * side);
    for y in 0..side {
        for x in 0..side {
            let v = (y * s1 + x) as u32;
            let s = s1 as u32;
            indices.push([v, v + 1, v + s + 1]);
            indices.push([v, v + s + 1, v + s]);
        }
    }
    TriMesh::new(vertices, indices).map_err(|e| CollisionError::Mesh(e.to_string()))
}

/// The triangles of an OBJ scene, scaled uniformly into the unit cube (so the same bodies
/// fit any scene).
pub fn scene_mesh(path: &Path) -> Result<TriMesh, CollisionError> {
    let arg = path.to_string_lossy();
    let scene = raytrace::SceneSource::parse(&arg)
        .and_then(|s| s.load(raytrace::SceneNeeds::AO))
        .map_err(|e| CollisionError::Scene(e.to_string()))?;
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in &scene.positions {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let scale = (0..3)
        .map(|a| hi[a] - lo[a])
        .fold(f32::MIN_POSITIVE, f32::max);
    let vertices = scene
        .positions
        .iter()
        .map(|p| {
            Vector::new(
                (p.x - lo[0]) / scale,
                (p.y - lo[1]) / scale,
                (p.z - lo[2]) / scale,
            )
        })
        .collect();
    TriMesh::new(vertices, scene.triangles.clone()).map_err(|e| CollisionError::Mesh(e.to_string()))
}
