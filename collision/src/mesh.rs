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

/// A triangle mesh (`vertices` indexed by `triangles`, such as a scene loaded from a file),
/// moved and scaled uniformly into the unit cube, so that the bodies of [`random_bodies`]
/// fit any mesh.
///
/// [`random_bodies`]: crate::random_bodies
pub fn unit_cube_mesh(
    vertices: &[[f32; 3]],
    triangles: Vec<[u32; 3]>,
) -> Result<TriMesh, CollisionError> {
    if let Some((index, vertex)) = vertices
        .iter()
        .enumerate()
        .find(|(_, v)| !v.iter().all(|x| x.is_finite()))
    {
        return Err(CollisionError::NonFinite {
            index,
            vertex: *vertex,
        });
    }
    let (lo, hi) = sched::locality::bounds(vertices);
    let scale = (0..3)
        .map(|a| hi[a] - lo[a])
        .fold(f32::MIN_POSITIVE, f32::max);
    let vertices = vertices
        .iter()
        .map(|p| {
            Vector::new(
                (p[0] - lo[0]) / scale,
                (p[1] - lo[1]) / scale,
                (p[2] - lo[2]) / scale,
            )
        })
        .collect();
    TriMesh::new(vertices, triangles).map_err(|e| CollisionError::Mesh(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mesh_is_scaled_into_the_unit_cube() {
        let vertices = [[10.0, 10.0, 10.0], [14.0, 10.0, 10.0], [10.0, 12.0, 11.0]];
        let mesh = unit_cube_mesh(&vertices, vec![[0, 1, 2]]).unwrap();
        let v = mesh.vertices();
        assert_eq!(v[0], Vector::new(0.0, 0.0, 0.0));
        assert_eq!(v[1], Vector::new(1.0, 0.0, 0.0));
        assert_eq!(v[2], Vector::new(0.0, 0.5, 0.25));
    }

    #[test]
    fn bad_meshes_name_the_fault() {
        let nan = unit_cube_mesh(&[[0.0; 3], [1.0, f32::NAN, 0.0]], vec![]);
        assert!(
            matches!(nan, Err(CollisionError::NonFinite { index: 1, .. })),
            "{nan:?}"
        );
        let empty = unit_cube_mesh(&[[0.0; 3]; 3], vec![]);
        assert!(matches!(empty, Err(CollisionError::Mesh(_))), "{empty:?}");
    }
}
