// What the trace kernels (`traverse.wgsl`) and the shading kernels (`paths/shading.wgsl`) share,
// put in front of each by the host: the ray record, a miss, and the watertight triangle test
// of Woop, Benthin and Wald (`triangle.rs`) in f32 only, operation for operation.

// `org.w` is tmin, `dir.w` is tmax.
struct GpuRay {
    org: vec4<f32>,
    dir: vec4<f32>,
}

// A hit's primitive for a miss.
const MISS: u32 = 0xffffffffu;

// The per-ray part of the watertight test (triangle.rs `RayShear`): the axes, the dominant
// one last, and the shear. A direction of zero gives `d[k.z] == 0`, which hits nothing.
struct Shear {
    k: vec3<u32>,
    s: vec3<f32>,
}

fn shear(d: vec3<f32>) -> Shear {
    let ad = abs(d);
    var kz = 2u;
    if ad.x >= ad.y && ad.x >= ad.z {
        kz = 0u;
    } else if ad.y >= ad.z {
        kz = 1u;
    }
    let dz = d[kz];
    var kx = select(kz + 1u, 0u, kz == 2u);
    var ky = select(kx + 1u, 0u, kx == 2u);
    if dz < 0.0 {
        let tmp = kx;
        kx = ky;
        ky = tmp;
    }
    return Shear(vec3<u32>(kx, ky, kz), vec3<f32>(d[kx] / dz, d[ky] / dz, 1.0 / dz));
}

fn permute(v: vec3<f32>, k: vec3<u32>) -> vec3<f32> {
    return vec3<f32>(v[k.x], v[k.y], v[k.z]);
}

// The test of the triangle `v0 v1 v2` against the ray from `o` sheared by `sh`, within
// [tmin, tmax]: (t, u, v) and `.w > 0` on a hit.
fn watertight(sh: Shear, o: vec3<f32>, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, tmin: f32, tmax: f32) -> vec4<f32> {
    let a = permute(v0 - o, sh.k);
    let b = permute(v1 - o, sh.k);
    let c = permute(v2 - o, sh.k);
    let ax = a.x - sh.s.x * a.z;
    let ay = a.y - sh.s.y * a.z;
    let bx = b.x - sh.s.x * b.z;
    let by = b.y - sh.s.y * b.z;
    let cx = c.x - sh.s.x * c.z;
    let cy = c.y - sh.s.y * c.z;
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    let miss = vec4<f32>(0.0);
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return miss;
    }
    let det = u + v + w;
    if det == 0.0 {
        return miss;
    }
    let az = sh.s.z * a.z;
    let bz = sh.s.z * b.z;
    let cz = sh.s.z * c.z;
    var t_scaled = u * az + v * bz + w * cz;
    var det_abs = det;
    if det < 0.0 {
        t_scaled = -t_scaled;
        det_abs = -det;
    }
    if t_scaled < tmin * det_abs || t_scaled > tmax * det_abs {
        return miss;
    }
    let rcp = 1.0 / det;
    return vec4<f32>(t_scaled / det_abs + 0.0, v * rcp, w * rcp, 1.0);
}

