// The TLAS refit on the GPU (`RayTracingScene::tlas_refit` = `TlasRefit::Gpu`, engine/src/rt/mod.rs):
// four dispatches in one compute pass labelled `tlas_refit`, recorded after the frame's uploads and
// before anything traces.
//
// 1. `clear_and_scatter`: every inner node of the binary TLAS (obvhs `Bvh2`) is emptied, the moved
//    leaves' world boxes (computed on the CPU, which keeps them in its own copy) are written into
//    their leaves, and the SAH cost's sum is zeroed.
// 2. `propagate`: one thread per leaf walks up to the root, merging its box into each ancestor with
//    atomicMin/atomicMax, and stops at the first ancestor its box does not grow. Sound with WGSL's
//    relaxed atomics (no fence needed): each bound is one word whose updates are totally ordered,
//    and the thread that last lowers (or raises) a word carries that value on up. Min and max are
//    exact, so the boxes are the CPU refit's bit for bit.
// 3. `measure`: the TLAS's normalized SAH cost, the half areas of its inner nodes over the root's
//    (the CPU's rebuild test, `TLAS_REBUILD_COST_RATIO`): each node's ratio in fixed point
//    (`COST_SCALE` a unit), summed per workgroup, then into a 64-bit sum (low word, high word) that
//    the CPU reads back a frame or two later. Integer sums: the same total in any order.
// 4. `encode`: every wide node (CWBVH, 80 bytes) gets its origin, exponents and quantized child boxes
//    from its source node's and its children's boxes, with `encode_bounds`'s arithmetic (a power-of-two
//    step from the float's bits, its exact reciprocal, floor/ceil, clamp to 0..255): the CPU's bytes.
//
// Boxes are stored as order-preserving integers (`to_ordered` on the CPU, `from_ordered` here), eight
// words a node: min x, y, z, unused, max x, y, z, unused.

const NONE: u32 = 0xffffffffu;
// Bits of `1.0f32 / 255.0` and `1e-20f32` (`encode_bounds`'s constants; a test compares them).
const ENCODE_INV_255_BITS: u32 = 0x3b808081u;
const ENCODE_MIN_EXTENT_BITS: u32 = 0x1e3ce508u;
// Fixed-point units in one of `measure`'s ratios (a ratio is at most 1: a child's box is inside its
// parent's). Mirrors `engine::rt::gpu_refit::TLAS_REFIT_COST_SCALE`.
const COST_SCALE: u32 = 1048576u;
// Wide node: 20 words; words 8..19 hold the child boxes (min x, max x, min y, max y, min z, max z, 8 bytes each).
const WIDE_NODE_WORDS: u32 = 20u;
// The wide map: the source node, then the node in each of the 8 slots (NONE: empty).
const WIDE_MAP_WORDS: u32 = 9u;

// Mirrors TlasRefitParams.
struct TlasRefitParams {
    moved: u32,
    inner: u32,
    leaves: u32,
    wide: u32,
}

// Mirrors TlasRefitLeaf: a moved leaf's world box (order-preserving integers).
struct TlasRefitLeaf {
    lo: vec3<u32>,
    leaf: u32,
    hi: vec3<u32>,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> tlas_refit_params: TlasRefitParams;
@group(0) @binding(1) var<storage, read> tlas_refit_moved: array<TlasRefitLeaf>;
@group(0) @binding(2) var<storage, read> tlas_refit_inner: array<u32>;
@group(0) @binding(3) var<storage, read> tlas_refit_leaves: array<u32>;
@group(0) @binding(4) var<storage, read> tlas_refit_parents: array<u32>;
@group(0) @binding(5) var<storage, read> tlas_refit_wide: array<u32>;
@group(0) @binding(6) var<storage, read_write> tlas_refit_boxes: array<atomic<u32>>;
@group(0) @binding(7) var<storage, read_write> tlas_nodes: array<u32>;
// The SAH cost's fixed-point sum: low word, high word.
@group(0) @binding(8) var<storage, read_write> tlas_refit_cost: array<atomic<u32>, 2>;

var<workgroup> measure_sum: atomic<u32>;

fn thread_index(id: vec3<u32>) -> u32 {
    return id.x + id.y * 65535u * 64u;
}

fn from_ordered(u: u32) -> f32 {
    return bitcast<f32>(select(~u, u & 0x7fffffffu, (u & 0x80000000u) != 0u));
}

fn box_min(node: u32) -> vec3<f32> {
    let b = 8u * node;
    return vec3<f32>(
        from_ordered(atomicLoad(&tlas_refit_boxes[b])),
        from_ordered(atomicLoad(&tlas_refit_boxes[b + 1u])),
        from_ordered(atomicLoad(&tlas_refit_boxes[b + 2u])),
    );
}

fn box_max(node: u32) -> vec3<f32> {
    let b = 8u * node + 4u;
    return vec3<f32>(
        from_ordered(atomicLoad(&tlas_refit_boxes[b])),
        from_ordered(atomicLoad(&tlas_refit_boxes[b + 1u])),
        from_ordered(atomicLoad(&tlas_refit_boxes[b + 2u])),
    );
}

@compute @workgroup_size(64)
fn clear_and_scatter(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = thread_index(id);
    if i == 0u {
        atomicStore(&tlas_refit_cost[0], 0u);
        atomicStore(&tlas_refit_cost[1], 0u);
    }
    if i < tlas_refit_params.inner {
        let b = 8u * tlas_refit_inner[i];
        for (var k = 0u; k < 3u; k++) {
            atomicStore(&tlas_refit_boxes[b + k], 0xffffffffu);
            atomicStore(&tlas_refit_boxes[b + 4u + k], 0u);
        }
    }
    if i < tlas_refit_params.moved {
        let m = tlas_refit_moved[i];
        let b = 8u * m.leaf;
        for (var k = 0u; k < 3u; k++) {
            atomicStore(&tlas_refit_boxes[b + k], m.lo[k]);
            atomicStore(&tlas_refit_boxes[b + 4u + k], m.hi[k]);
        }
    }
}

@compute @workgroup_size(64)
fn propagate(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = thread_index(id);
    if i >= tlas_refit_params.leaves {
        return;
    }
    let leaf = tlas_refit_leaves[i];
    var lo: array<u32, 3>;
    var hi: array<u32, 3>;
    for (var k = 0u; k < 3u; k++) {
        lo[k] = atomicLoad(&tlas_refit_boxes[8u * leaf + k]);
        hi[k] = atomicLoad(&tlas_refit_boxes[8u * leaf + 4u + k]);
    }
    var node = tlas_refit_parents[leaf];
    loop {
        if node == NONE {
            break;
        }
        // `|`, not `||`: every bound is merged.
        var grew = false;
        for (var k = 0u; k < 3u; k++) {
            grew = grew | (atomicMin(&tlas_refit_boxes[8u * node + k], lo[k]) > lo[k]);
            grew = grew | (atomicMax(&tlas_refit_boxes[8u * node + 4u + k], hi[k]) < hi[k]);
        }
        if !grew {
            break;
        }
        node = tlas_refit_parents[node];
    }
}

// obvhs `Aabb::half_area`'s arithmetic.
fn half_area(node: u32) -> f32 {
    let d = box_max(node) - box_min(node);
    return (d.x + d.y) * d.z + d.x * d.y;
}

@compute @workgroup_size(64)
fn measure(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let i = thread_index(id);
    if i < tlas_refit_params.inner {
        // Node 0 is the root. A root of no area (every instance a point): each ratio counts 1.
        let root = half_area(0u);
        let ratio = select(1.0, half_area(tlas_refit_inner[i]) / root, root > 0.0);
        atomicAdd(&measure_sum, u32(round(clamp(ratio, 0.0, 1.0) * f32(COST_SCALE))));
    }
    workgroupBarrier();
    if local == 0u {
        // At most 64 * COST_SCALE a workgroup; a carry out of the low word goes to the high one.
        let part = atomicLoad(&measure_sum);
        let old = atomicAdd(&tlas_refit_cost[0], part);
        if old + part < old {
            atomicAdd(&tlas_refit_cost[1], 1u);
        }
    }
}

// `encode_bounds`'s step: the smallest power of two at least extent / 255 (from the float's bits).
fn quantization_step(extent: f32) -> u32 {
    let bits = bitcast<u32>(max(extent, bitcast<f32>(ENCODE_MIN_EXTENT_BITS)) * bitcast<f32>(ENCODE_INV_255_BITS));
    let exponent = bits & 0x7f800000u;
    return select(exponent, exponent + 0x00800000u, (bits & 0x007fffffu) != 0u);
}

fn put_byte(word: u32, slot: u32, value: f32) -> u32 {
    let shift = (slot % 4u) * 8u;
    return (word & ~(0xffu << shift)) | (u32(value) << shift);
}

@compute @workgroup_size(64)
fn encode(@builtin(global_invocation_id) id: vec3<u32>) {
    let w = thread_index(id);
    if w >= tlas_refit_params.wide {
        return;
    }
    let map = WIDE_MAP_WORDS * w;
    let source = tlas_refit_wide[map];
    let p = box_min(source);
    let extent = box_max(source) - p;
    let e = vec3<u32>(quantization_step(extent.x), quantization_step(extent.y), quantization_step(extent.z)) >> vec3<u32>(23u);
    // 1 / 2^k exactly, as the CPU's division gives it.
    let rcp_e = bitcast<vec3<f32>>((vec3<u32>(254u) - e) << vec3<u32>(23u));
    let n = WIDE_NODE_WORDS * w;
    tlas_nodes[n] = bitcast<u32>(p.x);
    tlas_nodes[n + 1u] = bitcast<u32>(p.y);
    tlas_nodes[n + 2u] = bitcast<u32>(p.z);
    tlas_nodes[n + 3u] = (tlas_nodes[n + 3u] & 0xff000000u) | e.x | (e.y << 8u) | (e.z << 16u);
    var words: array<u32, 12>;
    for (var k = 0u; k < 12u; k++) {
        words[k] = tlas_nodes[n + 8u + k];
    }
    for (var s = 0u; s < 8u; s++) {
        let c = tlas_refit_wide[map + 1u + s];
        if c == NONE {
            continue;
        }
        let lo = clamp(floor((box_min(c) - p) * rcp_e), vec3<f32>(0.0), vec3<f32>(255.0));
        let hi = clamp(ceil((box_max(c) - p) * rcp_e), vec3<f32>(0.0), vec3<f32>(255.0));
        let half = s / 4u;
        words[half] = put_byte(words[half], s, lo.x);
        words[2u + half] = put_byte(words[2u + half], s, hi.x);
        words[4u + half] = put_byte(words[4u + half], s, lo.y);
        words[6u + half] = put_byte(words[6u + half], s, hi.y);
        words[8u + half] = put_byte(words[8u + half], s, lo.z);
        words[10u + half] = put_byte(words[10u + half], s, hi.z);
    }
    for (var k = 0u; k < 12u; k++) {
        tlas_nodes[n + 8u + k] = words[k];
    }
}
