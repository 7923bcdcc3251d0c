// A ground quad receiving the hair's shadow through hair_visibility (the renderer's WGSL, its
// bindings at group 0, comes before this): the receiver a game writes, here for the
// hair_shadow example and the tests. The ground's own uniform is at group 1.

struct Ground {
    view_proj: mat4x4<f32>,
    albedo: vec4<f32>,
}

@group(1) @binding(0) var<uniform> ground: Ground;

struct GroundOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
}

@vertex
fn ground_vs(@location(0) p: vec3<f32>) -> GroundOut {
    return GroundOut(ground.view_proj * vec4<f32>(p, 1.0), p);
}

@fragment
fn ground_fs(in: GroundOut) -> @location(0) vec4<f32> {
    let vis = hair_visibility(in.world);
    let lambert = max(hair.to_light.y, 0.0);
    return vec4<f32>(ground.albedo.rgb * (hair.ambient.rgb + hair.light_color.rgb * lambert * vis), 1.0);
}

@fragment
fn ground_fs_visibility(in: GroundOut) -> @location(0) vec4<f32> {
    return vec4<f32>(hair_visibility(in.world), 0.0, 0.0, 1.0);
}
