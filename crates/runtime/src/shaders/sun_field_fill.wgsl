// The sun-visibility field's first pass: each texel's ground and its horizon point in the two
// baked directions either side of the sun, read from the terrain (or the streamed tile) that
// holds it. Needs SCENE_WGSL, HORIZON_WGSL, terrain.wgsl (the tile, @group(0)) and
// sun_field_common.wgsl before it.

@group(1) @binding(0) var<uniform> field: SunFieldUniform;
@group(1) @binding(1) var<uniform> field_pass: SunFieldPass;
@group(1) @binding(2) var field_hops: texture_storage_2d_array<rgba32float, write>;
@group(1) @binding(3) var field_ground: texture_storage_2d_array<r32float, write>;

// Texel: (world height of the horizon point, its distance) in the first and the second walked
// direction; ground: the world height under the texel's centre (its node's).
@compute @workgroup_size(8, 8)
fn sun_field_fill(@builtin(global_invocation_id) id: vec3<u32>) {
    let t = field_pass.first + id.xy;
    if (any(t >= vec2<u32>(field.side))) {
        return;
    }
    let p = sun_field_inside(field, sun_field_centre(field, field_pass.level, vec2<i32>(t)));
    let local = (p - field_pass.offset) / terrain.texel_size;
    let size = vec2<f32>(terrain.size);
    let e = field_pass.edges;
    let before = local < vec2<f32>(0.0);
    let after = local >= size;
    if ((before.x && (e & 1u) == 0u) || (before.y && (e & 2u) == 0u) || (after.x && (e & 4u) == 0u) || (after.y && (e & 8u) == 0u)) {
        return;
    }
    let node = vec2<u32>(clamp(floor(local), vec2<f32>(0.0), size - 1.0));
    let ground = terrain_height(vec2<i32>(node));
    let a = horizon_load(terrain_horizon, terrain.encoding, node, u32(field.walk[0].z));
    let b = horizon_load(terrain_horizon, terrain.encoding, node, u32(field.walk[1].z));
    textureStore(field_hops, t, field_pass.level, vec4<f32>(ground + a.y * a.x, a.y, ground + b.y * b.x, b.y));
    textureStore(field_ground, t, field_pass.level, vec4<f32>(ground, 0.0, 0.0, 0.0));
}
