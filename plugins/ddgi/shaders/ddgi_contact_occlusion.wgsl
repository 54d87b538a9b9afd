// DDGI pass `ddgi_contact_occlusion`: contact occlusion (ddgi::DdgiContactOcclusion) at reduced
// resolution, one pixel of each ao_scale × ao_scale block a frame (another each frame), written to
// ddgi_occlusion for the composite to bring back to full resolution; −1 where that pixel shows no
// surface.
#include "ddgi_visibility.inc.wgsl"

@compute @workgroup_size(8, 8)
fn contact_occlusion(@builtin(global_invocation_id) id: vec3<u32>) {
    let blocks = ddgi_occlusion_blocks();
    if any(id.xy >= blocks) {
        return;
    }
    let pixel = ddgi_occlusion_sample_pixel(id.xy);
    let depth = textureLoad(gbuffer_depth, pixel, 0);
    var open = -1.0;
    if depth > 0.0 {
        open = ddgi_contact_occlusion_traced(pixel, view_world_position(pixel, depth), ddgi_pixel_normal(pixel));
    }
    ddgi_occlusion[id.y * blocks.x + id.x] = open;
}
