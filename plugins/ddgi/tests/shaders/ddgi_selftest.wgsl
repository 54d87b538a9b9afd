// Kernels that run single DDGI functions on a buffer of inputs, for the tests to compare with the
// CPU: octahedral round trips, spherical Fibonacci directions, SMAPE in YCoCg and the bfloat16
// packing of the slow error average.
#include "ddgi_common.inc.wgsl"

@group(3) @binding(0) var<storage, read> selftest_in: array<vec4<f32>>;
@group(3) @binding(1) var<storage, read_write> selftest_out: array<vec4<f32>>;

@compute @workgroup_size(64)
fn octahedral_round_trip(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&selftest_out) {
        return;
    }
    let d = selftest_in[id.x].xyz;
    let uv = ddgi_oct_encode(d);
    selftest_out[id.x] = vec4<f32>(ddgi_oct_decode(uv), max(abs(uv.x), abs(uv.y)));
}

// Direction i of n = arrayLength(selftest_out) spherical Fibonacci points.
@compute @workgroup_size(64)
fn fibonacci_directions(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = arrayLength(&selftest_out);
    if id.x >= n {
        return;
    }
    selftest_out[id.x] = vec4<f32>(ddgi_spherical_fibonacci(id.x, n), 0.0);
}

// SMAPE in YCoCg of the pairs (selftest_in[2i].rgb, selftest_in[2i + 1].rgb) with the floor
// selftest_in[2i].w, into selftest_out[i].x (the second half of the output is unused).
@compute @workgroup_size(64)
fn smape_pairs(@builtin(global_invocation_id) id: vec3<u32>) {
    if 2u * id.x + 1u >= arrayLength(&selftest_in) {
        return;
    }
    let a = selftest_in[2u * id.x];
    let b = selftest_in[2u * id.x + 1u];
    selftest_out[id.x] = vec4<f32>(ddgi_smape_ycocg(a.rgb, b.rgb, a.w), 0.0, 0.0, 0.0);
}

// selftest_in[i].xy packed as bfloat16 and unpacked, into selftest_out[i].xy.
@compute @workgroup_size(64)
fn bf16_round_trip(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&selftest_out) {
        return;
    }
    selftest_out[id.x] = vec4<f32>(ddgi_unpack_bf16(ddgi_pack_bf16(selftest_in[id.x].xy)), 0.0, 0.0);
}
