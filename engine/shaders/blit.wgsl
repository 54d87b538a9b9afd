// Copies an already tonemapped (sRGB-encoded) image to a window surface of a non-sRGB format.

@group(0) @binding(0) var blit_source: texture_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // One triangle covering the screen.
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

@fragment
fn fs_main(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    let size = textureDimensions(blit_source);
    let p = min(vec2<u32>(frag.xy), size - vec2<u32>(1u));
    return vec4<f32>(textureLoad(blit_source, p, 0).rgb, 1.0);
}
