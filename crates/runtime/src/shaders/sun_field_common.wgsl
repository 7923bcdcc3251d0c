// The terrain's sun-visibility field (hikage_runtime::horizon::SunField): what its receivers and
// its two build passes share. The field is a stack of camera-centred square levels in the map
// frame (x along +u, z along +v, y up, world units), each `side` texels a side and twice as
// coarse as the one before. A texel holds two world heights: below `lo` the sun's disc is hidden
// behind the terrain, above `hi` all of it is seen (lo = hi for a point sun).

struct SunFieldUniform {
    // World -> map frame.
    to_map: mat4x4<f32>,
    // Per level: xy the lower corner of texel (0, 0) in the map frame, zw the texel's size.
    levels: array<vec4<f32>, 8>,
    // Per walked direction (the two baked azimuths either side of the sun): xy the unit map-frame
    // direction toward the sun's side (u, v), z the baked direction's index, w its blend weight.
    walk: array<vec4<f32>, 2>,
    // x: tan of the elevation of the sun disc's top edge; y: of its bottom edge; z: the bake's
    // reach (world units); w: the floor under the ground a threshold is clamped to (in field texels).
    slopes: vec4<f32>,
    // The map's extent in the map frame, from (0, 0).
    map_size: vec2<f32>,
    // Texels a side of every level, and how many levels.
    side: u32,
    count: u32,
}

// One dispatch of a build pass: a block of one level's texels, against one tile (the fill) or
// the whole level (the walk).
struct SunFieldPass {
    // The tile's frame in the map frame: where its texel (0, 0)'s lower corner lies.
    offset: vec2<f32>,
    // The first texel of the block.
    first: vec2<u32>,
    level: u32,
    // The tile's sides on the map's edge (bits: 1 u = 0, 2 v = 0, 4 u last, 8 v last): it also
    // answers for the points past them.
    edges: u32,
    _pad: vec2<u32>,
}

// The texel of level `level` that holds map-frame point `p` (u, v), or -1 outside the level.
fn sun_field_texel(f: SunFieldUniform, level: u32, p: vec2<f32>) -> vec2<i32> {
    let l = f.levels[level];
    let t = floor((p - l.xy) / l.zw);
    if (any(t < vec2<f32>(0.0)) || any(t >= vec2<f32>(f32(f.side)))) {
        return vec2<i32>(-1);
    }
    return vec2<i32>(t);
}

// The centre of texel `t` of level `level`, map frame (u, v).
fn sun_field_centre(f: SunFieldUniform, level: u32, t: vec2<i32>) -> vec2<f32> {
    let l = f.levels[level];
    return l.xy + (vec2<f32>(t) + 0.5) * l.zw;
}

// `p` moved inside the map: a texel past the map's edge holds its edge's values.
fn sun_field_inside(f: SunFieldUniform, p: vec2<f32>) -> vec2<f32> {
    return clamp(p, vec2<f32>(0.0), f.map_size * (1.0 - 1e-6));
}

// The share of the sun's disc seen from world height `y` under thresholds (lo, hi): the disc's
// circular segment above the horizon, with the horizon's angle taken as linear in height between
// the two (exact at both ends).
fn sun_field_disc_visible(y: f32, lo: f32, hi: f32) -> f32 {
    if (hi <= lo) {
        return select(0.0, 1.0, y > lo);
    }
    let t = clamp((2.0 * y - lo - hi) / (hi - lo), -1.0, 1.0);
    return (acos(-t) + t * sqrt(1.0 - t * t)) / 3.141592653589793;
}
