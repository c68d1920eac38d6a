// A launch's counts, made on the device from what the host sent: the number of tasks (the
// header's third word) and each task's first path and length. The task list is rewritten in
// place to each task's first path and first slot (what `render.wgsl` and `sums.wgsl` read),
// and the header's other words are filled in: slots of the launch, primaries per probe chunk
// and secondary rays of the first chunk. `header.rs` holds the host's mirror of this
// arithmetic, which sizes the launch's buffers.

struct Setup {
    // Every `stride`-th path of a task has a slot (1 for a render, more for an estimate).
    stride: u32,
    // The most primaries whose probes fit one binding.
    fit: u32,
    // Secondary rays per path: AO probes, or one shadow ray per light.
    secondary: u32,
    pad: u32,
}

// Slots, chunk, tasks, secondary rays (`struct Header` in `header.rs`).
@group(0) @binding(0) var<storage, read_write> header: array<u32, 4>;
@group(0) @binding(1) var<storage, read_write> tasks: array<vec2<u32>>;
@group(0) @binding(2) var<uniform> setup: Setup;

@compute @workgroup_size(1)
fn main() {
    var slot = 0u;
    for (var i = 0u; i < header[2]; i++) {
        let t = tasks[i];
        tasks[i] = vec2<u32>(t.x, slot);
        // `ceil(len / stride)` without overflowing near 2^32.
        slot += t.y / setup.stride + select(0u, 1u, t.y % setup.stride != 0u);
    }
    let chunk = min(slot, setup.fit);
    header[0] = slot;
    header[1] = chunk;
    var secondary = 0xffffffffu;
    if setup.secondary == 0u || chunk <= 0xffffffffu / setup.secondary {
        secondary = chunk * setup.secondary;
    }
    header[3] = secondary;
}
