// The traversal without an alpha test: every surface is solid for the rays of the pipeline that
// includes this instead of rt_alpha.inc.wgsl (see ray_tracing.inc.wgsl). It reads no material,
// vertex or index, so a pass of few storage buffers (the direct light's shadow rays on a small GPU)
// still fits.
#include "ray_tracing.inc.wgsl"

fn rt_instance_alpha_tested(instance: u32) -> bool {
    return false;
}

fn rt_alpha_cuts(instance: u32, index: u32, barycentrics: vec2<f32>) -> bool {
    return false;
}
