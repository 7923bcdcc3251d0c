// The sun-visibility field's second pass: from each texel, the walk of horizon points of
// horizon_raised_angle (each point's own horizon point next) over the first pass's texels, which
// cross tiles and levels where the terrain's own textures end. Needs sun_field_common.wgsl
// before it.

@group(1) @binding(0) var<uniform> field: SunFieldUniform;
@group(1) @binding(1) var<uniform> field_pass: SunFieldPass;
@group(1) @binding(2) var field_hops: texture_2d_array<f32>;
@group(1) @binding(3) var field_ground: texture_2d_array<f32>;
@group(1) @binding(4) var field_thresholds: texture_storage_2d_array<rg32float, write>;

// Horizon points a walk visits at most (RAISED_HOPS of the horizon functions).
const SUN_FIELD_HOPS: u32 = 8u;

// The texel holding map-frame point `p` in level `finest` or the first coarser level that holds
// it: (column, row, level), level -1 when none does.
fn sun_field_find(finest: u32, p: vec2<f32>) -> vec3<i32> {
    for (var level = finest; level < field.count; level++) {
        let t = sun_field_texel(field, level, p);
        if (t.x >= 0) {
            return vec3<i32>(t, i32(level));
        }
    }
    return vec3<i32>(-1);
}

// The heights above which the sun disc's top edge (x) and all of it (y) are seen from above the
// texel's centre: the highest of each horizon point's height less the sun's slope times its
// distance, in both walked directions, blended; never below the floor under the ground.
@compute @workgroup_size(8, 8)
fn sun_field_walk(@builtin(global_invocation_id) id: vec3<u32>) {
    let t = vec2<i32>(id.xy);
    if (any(id.xy >= vec2<u32>(field.side))) {
        return;
    }
    let level = field_pass.level;
    let start = sun_field_inside(field, sun_field_centre(field, level, t));
    let l = field.levels[level];
    let lowest = textureLoad(field_ground, t, level, 0).x - field.slopes.w * max(l.z, l.w);
    var thresholds = vec2<f32>(0.0);
    for (var j = 0u; j < 2u; j++) {
        let w = field.walk[j];
        var best = vec2<f32>(-3.0e38);
        var far = 0.0;
        var p = start;
        for (var hop = 0u; hop < SUN_FIELD_HOPS; hop++) {
            let at = sun_field_find(level, p);
            if (at.z < 0) {
                break;
            }
            let hops = textureLoad(field_hops, at.xy, at.z, 0);
            let point = select(hops.xy, hops.zw, j == 1u);
            if (point.y <= 0.0 || far + point.y > field.slopes.z) {
                break;
            }
            far += point.y;
            best = max(best, vec2<f32>(point.x) - field.slopes.xy * far);
            p = start + w.xy * far;
            if (any(p < vec2<f32>(0.0)) || any(p >= field.map_size)) {
                break;
            }
        }
        thresholds += w.w * max(best, vec2<f32>(lowest));
    }
    textureStore(field_thresholds, t, level, vec4<f32>(thresholds, 0.0, 0.0));
}
