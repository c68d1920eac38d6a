// The GPU estimator's per-task sums (thesis, section 3.3), after the reduced traversal of
// `traverse.wgsl` (MODE 2, or 3 for the first-leaf walk) of the compacted sample: the host
// samples every task as `raytrace/src/cost/sample.rs` does and uploads only the sample, task
// after task; `main` then gives one workgroup to each task and adds the reduced-traversal counts
// of its samples in 64-bit integers (two u32 words with a carry), so the sums are exact and
// independent of the order of the additions.

struct Task {
    // Samples of the task.
    k: u32,
    // Where its samples start in `counts`.
    offset: u32,
}

const LANES: u32 = 64u;

@group(0) @binding(0) var<storage, read> tasks: array<Task>;
@group(0) @binding(1) var<storage, read> counts: array<vec2<u32>>;
// Per task: B low and high word, T low and high word.
@group(0) @binding(2) var<storage, read_write> sums: array<vec4<u32>>;
// `.x`: number of tasks.
@group(0) @binding(3) var<uniform> params: vec4<u32>;

var<workgroup> partial: array<vec4<u32>, LANES>;

// The task of this workgroup (the grid is two-dimensional: one dimension holds at most
// 65 535 workgroups).
fn task_index(wid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return wid.y * nwg.x + wid.x;
}

// `acc + x` for a 64-bit `acc` (low, high) and a 32-bit `x`.
fn add32(acc: vec2<u32>, x: u32) -> vec2<u32> {
    let lo = acc.x + x;
    return vec2<u32>(lo, acc.y + select(0u, 1u, lo < x));
}

// `a + b` for two 64-bit numbers (low, high).
fn add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < b.x));
}

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let t = task_index(wid, nwg);
    // Every invocation of a workgroup has the same `t`: the barrier in `sum_task` is reached
    // by all or by none.
    if t >= params.x {
        return;
    }
    sum_task(t, tasks[t].k, tasks[t].offset, lid);
}

// Task `t`'s sums over its `k` samples from `offset`, by the 64 invocations `lid`.
fn sum_task(t: u32, k: u32, offset: u32, lid: u32) {
    var b = vec2<u32>(0u, 0u);
    var c = vec2<u32>(0u, 0u);
    for (var j = lid; j < k; j += LANES) {
        let n = counts[offset + j];
        b = add32(b, n.x);
        c = add32(c, n.y);
    }
    partial[lid] = vec4<u32>(b, c);
    workgroupBarrier();
    if lid == 0u {
        var sb = vec2<u32>(0u, 0u);
        var st = vec2<u32>(0u, 0u);
        for (var i = 0u; i < LANES; i++) {
            let p = partial[i];
            sb = add64(sb, p.xy);
            st = add64(st, p.zw);
        }
        sums[t] = vec4<u32>(sb, st);
    }
}
