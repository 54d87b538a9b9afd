//! The ray tracer's host mirrors of WGSL structs, listed for the test that checks every field's
//! offset against naga's layout ([`crate::gpu_structs`]).

use super::TlasEntry;
use super::blas::GpuBlas;
use super::cpu::{GpuRay as Ray, TraceResult};
use super::gpu_refit::{TlasRefitLeaf, TlasRefitParams};

/// The ray tracer's host mirrors: BLAS records, TLAS entries, rays, the refit's and the trace's
/// structs.
pub(crate) fn gpu_layouts() -> Vec<crate::shader::HostStruct> {
    use crate::gpu_struct_layout as layout;
    vec![
        layout!(GpuBlas in "rt_alpha.inc.wgsl" { node_offset, triangle_offset, node_count, triangle_count, first_index, base_vertex, _pad0, _pad1 }),
        layout!(TlasEntry in "rt_alpha.inc.wgsl" { instance, node_offset, triangle_offset, start_node }),
        layout!(Ray in "rt_alpha.inc.wgsl" { origin, tmin, direction, tmax }),
        layout!(TlasRefitParams in "tlas_refit.wgsl" { moved, inner, leaves, wide }),
        layout!(TlasRefitLeaf in "tlas_refit.wgsl" { lo, leaf, hi, _pad }),
        layout!(TraceResult in "trace_rays.wgsl" { t, instance, primitive, flags, barycentrics, any_hit, _pad, albedo, emissive }),
    ]
}
