// The verdict of a launch: every trace's queue state folded into the one word the host reads
// back with the paths' values. Bit 0: a traversal loop was cut short; bit 1: a queue was not
// drained (its head is below its ray count; meaningless for one thread per ray, which uses no
// queue, and ignored by the host then).

struct State {
    // The trace's queue: head and loop-cut flag.
    head: u32,
    cut: u32,
    // The trace's ray count (the first word of its parameters).
    count: u32,
    pad: u32,
}

@group(0) @binding(0) var<storage, read> states: array<State>;
@group(0) @binding(1) var<storage, read_write> verdict: array<atomic<u32>, 4>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&states) {
        return;
    }
    let s = states[id.x];
    let v = select(0u, 1u, s.cut != 0u) | select(0u, 2u, s.head < s.count);
    if v != 0u {
        atomicOr(&verdict[0], v);
    }
}
