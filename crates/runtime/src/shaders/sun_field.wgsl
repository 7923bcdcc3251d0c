// A receiver's side of the sun-visibility field: bindings at @group(0) (moved to the group the
// game chose by SunField::wgsl) and sun_field_visibility. Needs sun_field_common.wgsl before it.

@group(0) @binding(0) var<uniform> sun_field: SunFieldUniform;
@group(0) @binding(1) var sun_field_thresholds: texture_2d_array<f32>;

// (lo, hi) at map-frame point `p` (u, v) in level `level`, bilinear over the texel centres, and
// how far inside the level `p` lies, in texels (0 at its edge).
fn sun_field_sample(level: u32, p: vec2<f32>) -> vec3<f32> {
    let l = sun_field.levels[level];
    let a = (p - l.xy) / l.zw - 0.5;
    let n = f32(sun_field.side) - 1.0;
    let inner = min(min(a.x, a.y), min(n - a.x, n - a.y));
    let c = clamp(a, vec2<f32>(0.0), vec2<f32>(n));
    let i = vec2<i32>(min(floor(c), vec2<f32>(n - 1.0)));
    let w = c - vec2<f32>(i);
    let t00 = textureLoad(sun_field_thresholds, i, level, 0).xy;
    let t10 = textureLoad(sun_field_thresholds, i + vec2<i32>(1, 0), level, 0).xy;
    let t01 = textureLoad(sun_field_thresholds, i + vec2<i32>(0, 1), level, 0).xy;
    let t11 = textureLoad(sun_field_thresholds, i + vec2<i32>(1, 1), level, 0).xy;
    let lohi = mix(mix(t00, t10, w.x), mix(t01, t11, w.x), w.y);
    return vec3<f32>(lohi, inner);
}

// The share of the sun's disc seen past the terrain from world point `world`: 1 in the open or
// off the map, 0 deep in a mountain's shadow. The finest level holding the point answers; in
// the outer eighth of a level it fades into the next, so levels meet without a seam.
fn sun_field_visibility(world: vec3<f32>) -> f32 {
    let p = (sun_field.to_map * vec4<f32>(world, 1.0)).xyz;
    if (any(p.xz < vec2<f32>(0.0)) || any(p.xz >= sun_field.map_size)) {
        return 1.0;
    }
    let band = max(f32(sun_field.side) / 8.0, 1.0);
    for (var level = 0u; level < sun_field.count; level++) {
        let s = sun_field_sample(level, p.xz);
        if (s.z < 0.0) {
            continue;
        }
        let v = sun_field_disc_visible(p.y, s.x, s.y);
        if (s.z >= band || level + 1u >= sun_field.count) {
            return v;
        }
        let next = sun_field_sample(level + 1u, p.xz);
        return mix(sun_field_disc_visible(p.y, next.x, next.y), v, s.z / band);
    }
    return 1.0;
}
