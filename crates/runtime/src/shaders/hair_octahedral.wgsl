// Octahedral unit vectors, as strand records store tangents (hikage_bundle::strands).

// The unit vector of an octahedral encoding (hikage_bundle::strands::oct_encode).
fn hair_oct_decode(e: vec2<f32>) -> vec3<f32> {
    let f = e * 2.0 - 1.0;
    var n = vec3<f32>(f.x, f.y, 1.0 - abs(f.x) - abs(f.y));
    let t = max(-n.z, 0.0);
    n.x = select(n.x + t, n.x - t, n.x >= 0.0);
    n.y = select(n.y + t, n.y - t, n.y >= 0.0);
    return normalize(n);
}

// The octahedral encoding of a unit vector, 0–1 a component (hikage_bundle::strands::oct_encode
// before its 16-bit rounding).
fn hair_oct_encode(v: vec3<f32>) -> vec2<f32> {
    let l1 = abs(v.x) + abs(v.y) + abs(v.z);
    if l1 <= 0.0 {
        return vec2<f32>(0.5);
    }
    var e = v.xy / l1;
    if v.z < 0.0 {
        let s = select(vec2<f32>(-1.0), vec2<f32>(1.0), e >= vec2<f32>(0.0));
        e = (1.0 - abs(e.yx)) * s;
    }
    return e * 0.5 + 0.5;
}
