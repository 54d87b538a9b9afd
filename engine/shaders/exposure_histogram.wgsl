// Pass `exposure_histogram` (auto-exposure, engine::render::exposure): every pixel's luminance
// (linear radiance, before exposure) counted into 64 bins of log₂ luminance spanning the
// auto-exposure's range of exposure values; black and non-finite pixels go to the darkest bin.
#include "exposure.inc.wgsl"

@group(1) @binding(1) var exposure_hdr: texture_2d<f32>;
@group(1) @binding(2) var<storage, read_write> exposure_histogram: array<atomic<u32>, EXPOSURE_BINS>;

var<workgroup> bins: array<atomic<u32>, EXPOSURE_BINS>;

@compute @workgroup_size(16, 16)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    if local < EXPOSURE_BINS {
        atomicStore(&bins[local], 0u);
    }
    workgroupBarrier();
    if all(id.xy < view.size) {
        let l = luminance(sanitize_radiance(textureLoad(exposure_hdr, id.xy, 0).rgb));
        atomicAdd(&bins[exposure_bin(l)], 1u);
    }
    workgroupBarrier();
    if local < EXPOSURE_BINS {
        let n = atomicLoad(&bins[local]);
        if n > 0u {
            atomicAdd(&exposure_histogram[local], n);
        }
    }
}
