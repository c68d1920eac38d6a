// The GPU-only ambient-occlusion render (issue 5): primary rays in Morton order, AO probes
// with the CPU's Halton points and per-pixel scrambling, and the image, each stage a kernel
// over buffers that stay on the device (the traces between them are `traverse.wgsl`'s).
// The host puts `shading.wgsl` in front. Every function mirrors its CPU counterpart operation
// for operation, in f32:
// - `raygen`: `Camera::ray` and `camera::morton_order` (the pixel's rank among the image's
//   Morton keys is counted directly, so no sort is needed);
// - `shade_ao`: `ao::ao_rays` (re-intersection, `Scene::surface_point`, `spawn.rs`'s offset,
//   `Rng`'s SplitMix64 in pairs of u32, `cosine_hemisphere`, glam's `any_orthonormal_pair`);
// - `accumulate`: `shade::ao::render`'s fraction of open probes.
// Where results may differ from the CPU: `cos`/`sin` (WGSL does not require correct
// rounding; Rust calls the C library's), and an edge function that is exactly 0, which the
// CPU re-evaluates in f64 (as in `traverse.wgsl`).


struct Params {
    // Camera: eye, and the frame `Camera::ray` builds (forward, right, up), `.w` unused.
    eye: vec4<f32>,
    fwd: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    // Half extents of the image plane `w`, `h`; probe length; gamma(8).
    plane_w: f32,
    plane_h: f32,
    max_distance: f32,
    gamma8: f32,
    width: u32,
    height: u32,
    // Primary rays (pixels).
    count: u32,
    // Probes per primary hit.
    samples: u32,
    // First primary ray of this chunk, and primaries in it (shade and accumulate).
    base: u32,
    chunk: u32,
    // The AO seed's low and high words.
    seed_lo: u32,
    seed_hi: u32,
}


@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> primary: array<GpuRay>;
@group(0) @binding(2) var<storage, read_write> pixels: array<u32>;
@group(0) @binding(3) var<storage, read> hits: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read> scene_tris: array<SceneTri>;
// Halton points (radical inverses in bases 2 and 3 of 1..=samples), from the host.
@group(0) @binding(5) var<storage, read> halton: array<vec2<f32>>;
@group(0) @binding(6) var<storage, read_write> probes: array<GpuRay>;
@group(0) @binding(7) var<storage, read> probe_hits: array<vec2<u32>>;
@group(0) @binding(8) var<storage, read_write> film: array<f32>;

// ---- raygen ----

// Bits of `v` (16 of them) spread to the even positions (`camera.rs`'s `spread`).
fn spread(v: u32) -> u32 {
    var x = v & 0xffffu;
    x = (x | (x << 8u)) & 0x00ff00ffu;
    x = (x | (x << 4u)) & 0x0f0f0f0fu;
    x = (x | (x << 2u)) & 0x33333333u;
    return (x | (x << 1u)) & 0x55555555u;
}

// The inverse of `spread`: the even bits of `k`, packed.
fn compact(k: u32) -> u32 {
    var x = k & 0x55555555u;
    x = (x | (x >> 1u)) & 0x33333333u;
    x = (x | (x >> 2u)) & 0x0f0f0f0fu;
    x = (x | (x >> 4u)) & 0x00ff00ffu;
    return (x | (x >> 8u)) & 0x0000ffffu;
}

// Pixels of the image whose Morton key is below `key`: for every set bit `b` of `key`, the
// keys sharing its bits above `b` with a 0 at `b` form an aligned block of the Z-curve, whose
// pixels inside the image are counted as a rectangle. This is the pixel's index in the CPU's
// sorted `morton_order`.
fn morton_rank(key: u32) -> u32 {
    var rank = 0u;
    for (var b = 0u; b < 32u; b++) {
        if (key & (1u << b)) == 0u {
            continue;
        }
        // The block's lowest key: the bits above `b`, bit `b` cleared, the rest 0.
        let low = (key >> b >> 1u) << b << 1u;
        // Free x bits are the even positions below `b`, free y bits the odd ones.
        let fx = (b + 1u) / 2u;
        let fy = b / 2u;
        let x0 = compact(low);
        let y0 = compact(low >> 1u);
        let cx = select(0u, min(params.width - x0, 1u << fx), x0 < params.width);
        let cy = select(0u, min(params.height - y0, 1u << fy), y0 < params.height);
        rank += cx * cy;
    }
    return rank;
}

@compute @workgroup_size(64)
fn raygen(inv: Invocation) {
    let p = flat(inv);
    if p >= params.count {
        return;
    }
    let x = p % params.width;
    let y = p / params.width;
    let rank = morton_rank(spread(x) | (spread(y) << 1u));
    let fw = f32(params.width);
    let fh = f32(params.height);
    let px = (((f32(x) + 0.5) / fw) * 2.0 - 1.0) * params.plane_w;
    let py = (1.0 - ((f32(y) + 0.5) / fh) * 2.0) * params.plane_h;
    let d = (params.fwd.xyz + px * params.right.xyz) + py * params.up.xyz;
    let dir = d * (1.0 / sqrt(dot3(d, d)));
    primary[rank] = GpuRay(vec4<f32>(params.eye.xyz, 0.0), vec4<f32>(dir, bitcast<f32>(0x7f800000u)));
    pixels[rank] = p;
}

// ---- AO probes ----

// 64-bit integers as (low, high) words, for `Rng`'s SplitMix64.
fn add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

// The full 64-bit product of two u32.
fn mul_wide(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return vec2<u32>((p00 & 0xffffu) | (mid << 16u), p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u));
}

// Wrapping 64-bit product.
fn mul64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = mul_wide(a.x, b.x);
    return vec2<u32>(lo.x, lo.y + a.x * b.y + a.y * b.x);
}

// `z >> s` for 0 < s < 32.
fn shr64(z: vec2<u32>, s: u32) -> vec2<u32> {
    return vec2<u32>((z.x >> s) | (z.y << (32u - s)), z.y >> s);
}

const GOLDEN: vec2<u32> = vec2<u32>(0x7f4a7c15u, 0x9e3779b9u);

// `Rng::next_u64`, advancing `state`.
fn next_u64(state: ptr<function, vec2<u32>>) -> vec2<u32> {
    *state = add64(*state, GOLDEN);
    var z = *state;
    z = mul64(z ^ shr64(z, 30u), vec2<u32>(0x1ce4e5b9u, 0xbf58476du));
    z = mul64(z ^ shr64(z, 27u), vec2<u32>(0x133111ebu, 0x94d049bbu));
    return z ^ shr64(z, 31u);
}

// `Rng::f32`: the top 24 bits, exactly representable.
fn next_f32(state: ptr<function, vec2<u32>>) -> f32 {
    return f32(next_u64(state).y >> 8u) * (1.0 / 16777216.0);
}

// Writes the probes of primary ray `i` to slots `(i - base)·samples ..`; a primary that
// spawns none (a miss) gets probes with an empty range, which `accumulate` does not count.
@compute @workgroup_size(64)
fn shade_ao(inv: Invocation) {
    let k = flat(inv);
    if k >= params.chunk {
        return;
    }
    let i = params.base + k;
    let first = k * params.samples;
    let hit = hits[i];
    let r = primary[i];
    var ok = hit.y != MISS;
    var q = vec4<f32>(0.0);
    var tri: SceneTri;
    if ok {
        tri = scene_tris[hit.y];
        q = intersect(r.org.xyz, r.dir.xyz, tri, r.org.w, max(r.dir.w, bitcast<f32>(hit.x)));
        ok = q.w > 0.0;
    }
    if !ok {
        for (var s = 0u; s < params.samples; s++) {
            probes[first + s] = no_ray();
        }
        return;
    }
    let sp = surface_point(tri, q.y, q.z, params.gamma8);
    let n = sp.n;
    let facing = select(-n, n, dot3(n, r.dir.xyz) < 0.0);
    // `Rng::new(seed ^ i·golden)` (the state starts xor-ed with the golden ratio again).
    var state = mul64(vec2<u32>(i, 0u), GOLDEN) ^ vec2<u32>(params.seed_lo, params.seed_hi) ^ GOLDEN;
    let s1 = next_f32(&state);
    let s2 = next_f32(&state);
    // glam's `any_orthonormal_pair` of `facing`.
    let sign = signum(facing.z);
    let a = -1.0 / (sign + facing.z);
    let bb = facing.x * facing.y * a;
    let tan = vec3<f32>(1.0 + sign * facing.x * facing.x * a, sign * bb, -sign * facing.x);
    let bit = vec3<f32>(bb, sign + facing.y * facing.y * a, -facing.y);
    for (var s = 0u; s < params.samples; s++) {
        let h = halton[s];
        let u1 = fract(h.x + s1);
        let u2 = fract(h.y + s2);
        // `cosine_hemisphere`.
        let rr = sqrt(u1);
        let phi = bitcast<f32>(0x40c90fdbu) * u2;
        let z = sqrt(max(1.0 - u1, 0.0));
        let dir = normalize_or(
            (tan * (rr * cos(phi)) + bit * (rr * sin(phi))) + facing * z,
            facing,
        );
        let po = offset_origin(sp, dir, params.gamma8);
        probes[first + s] = GpuRay(vec4<f32>(po, 0.0), vec4<f32>(dir, params.max_distance));
    }
}

// The pixel of primary ray `i`: the fraction of its probes that escaped, 1 without probes.
@compute @workgroup_size(64)
fn accumulate(inv: Invocation) {
    let k = flat(inv);
    if k >= params.chunk {
        return;
    }
    let i = params.base + k;
    let first = k * params.samples;
    var sent = 0u;
    var open = 0u;
    for (var s = 0u; s < params.samples; s++) {
        // Empty-range probes stand for none.
        if probes[first + s].org.w <= probes[first + s].dir.w {
            sent += 1u;
            if probe_hits[first + s].y == MISS {
                open += 1u;
            }
        }
    }
    var value = 1.0;
    if sent != 0u {
        value = f32(open) / f32(sent);
    }
    film[pixels[i]] = value;
}
