// Shading helpers shared by the GPU render kernels (`render.wgsl`, `whitted.wgsl`; the host
// puts this file in front of each), each mirroring its CPU counterpart operation for operation
// in f32: glam's vector operations, `triangle.rs`'s watertight test with barycentrics,
// `Scene::surface_point` and `spawn.rs`'s offset origin. Where they may differ from the CPU:
// an edge function that is exactly 0, which the CPU re-evaluates in f64.

// A triangle of the scene by primitive id (`Scene::vertices`), `.w` unused.
struct SceneTri {
    v0: vec4<f32>,
    v1: vec4<f32>,
    v2: vec4<f32>,
}

const F32_MAX: f32 = 3.40282347e38;

// What a kernel's invocation knows of where it stands: every kernel takes one item.
struct Invocation {
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
}

// Invocation index in a two-dimensional grid of 64-wide workgroups.
fn flat(inv: Invocation) -> u32 {
    return (inv.wid.y * inv.nwg.x + inv.wid.x) * 64u + inv.lid;
}

// A ray with an empty range: traced, it misses at once.
fn no_ray() -> GpuRay {
    return GpuRay(vec4<f32>(0.0, 0.0, 0.0, 1.0), vec4<f32>(1.0, 0.0, 0.0, 0.0));
}

// ---- vector helpers with glam's operation order ----

fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return ((a.x * b.x) + (a.y * b.y)) + (a.z * b.z);
}

fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
}

fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

// `Vec3::normalize_or`.
fn normalize_or(v: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let rcp = 1.0 / sqrt(dot3(v, v));
    if is_finite(rcp) && rcp > 0.0 {
        return v * rcp;
    }
    return fallback;
}

// `f32::signum` (1 for +0, -1 for -0).
fn signum(x: f32) -> f32 {
    return select(1.0, -1.0, (bitcast<u32>(x) & 0x80000000u) != 0u);
}

// `spawn.rs`'s `next_float_up` / `next_float_down` for finite values.
fn next_up(v: f32) -> f32 {
    if v == 0.0 {
        return bitcast<f32>(1u);
    }
    let bits = bitcast<u32>(v);
    return bitcast<f32>(select(bits - 1u, bits + 1u, v > 0.0));
}

fn next_down(v: f32) -> f32 {
    if v == 0.0 {
        return bitcast<f32>(0x80000001u);
    }
    let bits = bitcast<u32>(v);
    return bitcast<f32>(select(bits - 1u, bits + 1u, v < 0.0));
}

// The watertight test returning (t, u, v) and `.w > 0` on a hit (`intersect_watertight`).
fn intersect(o: vec3<f32>, d: vec3<f32>, tri: SceneTri, tmin: f32, tmax: f32) -> vec4<f32> {
    let sh = shear(d);
    if d[sh.k.z] == 0.0 {
        return vec4<f32>(0.0);
    }
    return watertight(sh, o, tri.v0.xyz, tri.v1.xyz, tri.v2.xyz, tmin, tmax);
}

// `Scene::surface_point` of barycentrics `(u, v)` on `tri`: the point, its error bound, the
// unit normal of the winding and the reach.
struct SurfacePoint {
    p: vec3<f32>,
    err: vec3<f32>,
    n: vec3<f32>,
    reach: f32,
}

fn surface_point(tri: SceneTri, u: f32, v: f32, gamma8: f32) -> SurfacePoint {
    let p0 = tri.v0.xyz;
    let p1 = tri.v1.xyz;
    let p2 = tri.v2.xyz;
    let b0 = max((1.0 - u) - v, 0.0);
    let p = ((b0 * p0) + (u * p1)) + (v * p2);
    let err = gamma8 * ((abs(b0 * p0) + abs(u * p1)) + abs(v * p2));
    let cross = cross3(p1 - p0, p2 - p0);
    let d = max(max(abs(p0 - p), abs(p1 - p)), abs(p2 - p));
    let r = max(d.x, max(d.y, d.z));
    let reach = min(256.0 * gamma8 * (r / sqrt(dot3(cross, cross)) * r) * r, F32_MAX);
    return SurfacePoint(p, err, normalize_or(cross, vec3<f32>(0.0)), reach);
}

// `offset_ray_origin`: `sp.p` pushed off the surface along the normal, to the side of `w`, by
// the error bound, then one ulp further out.
fn offset_origin(sp: SurfacePoint, w: vec3<f32>, gamma8: f32) -> vec3<f32> {
    let ap = abs(sp.p);
    let d = max(
        max(max(dot3(abs(sp.n), sp.err), gamma8 * max(ap.x, max(ap.y, ap.z))), sp.reach),
        bitcast<f32>(0x00800000u),
    );
    var offset = d * sp.n;
    if dot3(w, sp.n) < 0.0 {
        offset = -offset;
    }
    var po = sp.p + offset;
    for (var c = 0u; c < 3u; c++) {
        if offset[c] > 0.0 {
            po[c] = next_up(po[c]);
        } else if offset[c] < 0.0 {
            po[c] = next_down(po[c]);
        }
    }
    return po;
}
