// Whitted shading on the GPU, mirroring `shade/whitted.rs` and `shade/surface.rs`
// operation for operation in f32 (the host puts `shading.wgsl` in front). One path per slot of
// the launch; a generation keeps every path's slot, and a path that
// ended (a miss, or no mirror) traces an empty-range ray that ends at once and adds nothing:
// - `shade`: a hit's emission, ambient term, one shadow ray per light facing the surface
//   (with what it adds if nothing blocks it), and the mirror ray with the path's new weight;
//   a miss adds the sky;
// - `shadows`: the unblocked shadow rays' light, in light order (the CPU's order of additions
//   to each pixel, so sums round alike).

struct Params {
    // Sky radiance (`.w` unused).
    sky: vec4<f32>,
    // Paths (pixels).
    count: u32,
    lights: u32,
    // This generation's bounce, and the last bounce that spawns mirror rays.
    bounce: u32,
    bounces: u32,
    gamma8: f32,
    ambient: f32,
    // `tmax` of shadow rays: 1 - 1e-4 as the CPU rounds it.
    shadow_tmax: f32,
    // 1 when the scene has vertex normals.
    has_normals: u32,
}

// Per primitive: material and (when the scene has them) vertex normals.
struct PrimShading {
    // Diffuse albedo, and the reflectance in `.w`.
    diffuse: vec4<f32>,
    emission: vec4<f32>,
    n0: vec4<f32>,
    n1: vec4<f32>,
    n2: vec4<f32>,
}

struct Light {
    position: vec4<f32>,
    intensity: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> rays: array<GpuRay>;
@group(0) @binding(2) var<storage, read> hits: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read> scene_tris: array<SceneTri>;
@group(0) @binding(4) var<storage, read> prims: array<PrimShading>;
@group(0) @binding(5) var<storage, read> lights: array<Light>;
// Per path: its weight, and `.w` 1 while it is alive.
@group(0) @binding(6) var<storage, read_write> paths: array<vec4<f32>>;
// Per slot: its path's rank (unused here: a path's value stays in its slot).
@group(0) @binding(7) var<storage, read> ranks: array<u32>;
// Per path: linear RGB (`.w` unused).
// Three words a path, red, green and blue: 12 B read back, not a padded 16.
@group(0) @binding(8) var<storage, read_write> film: array<f32>;
@group(0) @binding(9) var<storage, read_write> shadow_rays: array<GpuRay>;
// Per shadow slot: the light it adds if unblocked, `.w` 1 when the ray was spawned.
@group(0) @binding(10) var<storage, read_write> shadow_light: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read> shadow_hits: array<vec2<u32>>;
@group(0) @binding(12) var<storage, read_write> next_rays: array<GpuRay>;

fn add(pixel: u32, value: vec3<f32>) {
    let at = 3u * pixel;
    film[at] += value.x;
    film[at + 1u] += value.y;
    film[at + 2u] += value.z;
}

// `d` mirrored about the plane with unit normal `n` (`whitted.rs`'s `reflect`).
fn reflect3(d: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return d - (2.0 * dot3(d, n)) * n;
}

// Barycentrics of the hit of `r` on `tri` at `t` (`surface.rs`'s `full_hit`): the watertight
// test again, or, should it miss, those of the point at `t`.
fn full_hit(r: GpuRay, tri: SceneTri, t: f32) -> vec2<f32> {
    let q = intersect(r.org.xyz, r.dir.xyz, tri, r.org.w, max(r.dir.w, t));
    if q.w > 0.0 {
        return q.yz;
    }
    let p0 = tri.v0.xyz;
    let e1 = tri.v1.xyz - p0;
    let e2 = tri.v2.xyz - p0;
    let d = (r.org.xyz + t * r.dir.xyz) - p0;
    let d11 = dot3(e1, e1);
    let d12 = dot3(e1, e2);
    let d22 = dot3(e2, e2);
    let den = d11 * d22 - d12 * d12;
    if den > 0.0 {
        let u = clamp((d22 * dot3(d, e1) - d12 * dot3(d, e2)) / den, 0.0, 1.0);
        let v = clamp((d11 * dot3(d, e2) - d12 * dot3(d, e1)) / den, 0.0, 1.0 - u);
        return vec2<f32>(u, v);
    }
    let third = bitcast<f32>(0x3eaaaaabu);
    return vec2<f32>(third, third);
}

@compute @workgroup_size(64)
fn shade(inv: Invocation) {
    let k = flat(inv);
    if k >= params.count {
        return;
    }
    let first = k * params.lights;
    for (var l = 0u; l < params.lights; l++) {
        shadow_rays[first + l] = no_ray();
        shadow_light[first + l] = vec4<f32>(0.0);
    }
    next_rays[k] = no_ray();
    let path = paths[k];
    if path.w == 0.0 {
        return;
    }
    let weight = path.xyz;
    let pixel = k;
    let hit = hits[k];
    if hit.y == MISS {
        add(pixel, weight * params.sky.xyz);
        paths[k] = vec4<f32>(0.0);
        return;
    }
    let r = rays[k];
    let tri = scene_tris[hit.y];
    let uv = full_hit(r, tri, bitcast<f32>(hit.x));
    let sp = surface_point(tri, uv.x, uv.y, params.gamma8);
    let geometric = select(sp.n, -sp.n, dot3(sp.n, r.dir.xyz) > 0.0);
    let prim = prims[hit.y];
    var normal = geometric;
    if params.has_normals != 0u {
        let b0 = (1.0 - uv.x) - uv.y;
        let s = normalize_or(((b0 * prim.n0.xyz) + (uv.x * prim.n1.xyz)) + (uv.y * prim.n2.xyz), geometric);
        normal = select(s, -s, dot3(s, geometric) < 0.0);
    }
    let reflectance = prim.diffuse.w;
    add(pixel, weight * prim.emission.xyz);
    let kd = (weight * prim.diffuse.xyz) * (1.0 - reflectance);
    if any(kd != vec3<f32>(0.0)) {
        add(pixel, kd * params.ambient);
        for (var l = 0u; l < params.lights; l++) {
            let light = lights[l];
            let to = light.position.xyz - sp.p;
            let d2 = dot3(to, to);
            let dir = to / sqrt(d2);
            let cos = dot3(normal, dir);
            if !(d2 > 0.0 && cos > 0.0 && dot3(geometric, dir) > 0.0) {
                continue;
            }
            // `spawn_ray_to`.
            let o = offset_origin(sp, light.position.xyz - sp.p, params.gamma8);
            shadow_rays[first + l] = GpuRay(vec4<f32>(o, 0.0), vec4<f32>(light.position.xyz - o, params.shadow_tmax));
            shadow_light[first + l] = vec4<f32>((kd * light.intensity.xyz) * (cos / d2), 1.0);
        }
    }
    if reflectance > 0.0 && params.bounce < params.bounces {
        let d = normalize_or(r.dir.xyz, vec3<f32>(0.0));
        var m = reflect3(d, normal);
        // A shading normal can mirror a ray into the surface; fall back to the true one.
        if dot3(m, geometric) <= 0.0 {
            m = reflect3(d, geometric);
        }
        next_rays[k] = GpuRay(vec4<f32>(offset_origin(sp, m, params.gamma8), 0.0), vec4<f32>(m, bitcast<f32>(0x7f800000u)));
        paths[k] = vec4<f32>(weight * reflectance, 1.0);
    } else {
        paths[k] = vec4<f32>(0.0);
    }
}

// Every path of the launch alive, with weight 1, and nothing added yet.
@compute @workgroup_size(64)
fn start(inv: Invocation) {
    let k = flat(inv);
    if k >= params.count {
        return;
    }
    paths[k] = vec4<f32>(1.0);
    film[3u * k] = 0.0;
    film[3u * k + 1u] = 0.0;
    film[3u * k + 2u] = 0.0;
}

@compute @workgroup_size(64)
fn shadows(inv: Invocation) {
    let k = flat(inv);
    if k >= params.count {
        return;
    }
    let first = k * params.lights;
    for (var l = 0u; l < params.lights; l++) {
        let light = shadow_light[first + l];
        if light.w > 0.0 && shadow_hits[first + l].y == MISS {
            add(k, light.xyz);
        }
    }
}
