// A triangle covering the whole target: the vertex stage of the per-pixel scenes
// (horizon_sphere, relief_plane), whose fragment stage computes each pixel's ray itself.

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let p = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(p * 2.0 - 1.0, 0.0, 1.0);
}
