
// The skinning pass: every strand record posed by the scalp triangle its strand is bound to.
// A strand moves rigidly with the frame of its triangle (origin at the bound point, axes from the
// first edge and the face normal): rest frame from the bind-pose vertices, posed frame from the
// same vertices skinned by the joint matrices (linear blend, up to four joints a vertex).
// One invocation per record; records keep their layout, position and tangent replaced.

struct SkinParams {
    points: u32,
    joint_count: u32,
    strands: u32,
    // Workgroups along x of the dispatch (it spills into y past the device's limit).
    groups_x: u32,
    // Offsets and strides, in 4-byte words, of the scalp's and the binding's streams.
    position_at: u32,
    position_stride: u32,
    joints_at: u32,
    joints_stride: u32,
    weights_at: u32,
    weights_stride: u32,
    index_at: u32,
    triangle_at: u32,
    triangle_stride: u32,
    barycentric_at: u32,
    barycentric_stride: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> skin: SkinParams;
@group(0) @binding(1) var<storage, read> skin_rest: array<u32>;
@group(0) @binding(2) var<storage, read_write> skin_posed: array<u32>;
@group(0) @binding(3) var<storage, read> skin_binding: array<u32>;
@group(0) @binding(4) var<storage, read> skin_scalp: array<u32>;
@group(0) @binding(5) var<storage, read> skin_joints: array<mat4x4<f32>>;

// Scalp vertex `v` in the bind pose.
fn skin_rest_vertex(v: u32) -> vec3<f32> {
    let at = skin.position_at + v * skin.position_stride;
    return vec3<f32>(bitcast<f32>(skin_scalp[at]), bitcast<f32>(skin_scalp[at + 1u]), bitcast<f32>(skin_scalp[at + 2u]));
}

// Scalp vertex `v` skinned: Σ weight × joint matrix × bind-pose position.
fn skin_posed_vertex(v: u32) -> vec3<f32> {
    let p = vec4<f32>(skin_rest_vertex(v), 1.0);
    let ja = skin.joints_at + v * skin.joints_stride;
    let wa = skin.weights_at + v * skin.weights_stride;
    let j = vec4<u32>(skin_scalp[ja] & 0xffffu, skin_scalp[ja] >> 16u, skin_scalp[ja + 1u] & 0xffffu, skin_scalp[ja + 1u] >> 16u);
    let w = vec4<f32>(unpack2x16unorm(skin_scalp[wa]), unpack2x16unorm(skin_scalp[wa + 1u]));
    var out = vec3<f32>(0.0);
    for (var k = 0u; k < 4u; k++) {
        if w[k] > 0.0 {
            out += w[k] * (skin_joints[min(j[k], skin.joint_count - 1u)] * p).xyz;
        }
    }
    return out;
}

// A triangle's frame: the first edge, the face normal, and the axis across both.
fn skin_frame(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> mat3x3<f32> {
    let t = normalize(b - a);
    let n = normalize(cross(b - a, c - a));
    return mat3x3<f32>(t, cross(n, t), n);
}

@compute @workgroup_size(64)
fn hair_skin(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * skin.groups_x * 64u;
    if i >= skin.points {
        return;
    }
    let r = i * 8u;
    let strand = skin_rest[r + 7u];
    for (var k = 3u; k < 8u; k++) {
        skin_posed[r + k] = skin_rest[r + k];
    }
    if strand >= skin.strands {
        for (var k = 0u; k < 3u; k++) {
            skin_posed[r + k] = skin_rest[r + k];
        }
        return;
    }
    let tri = skin_binding[skin.triangle_at + strand * skin.triangle_stride];
    let b = unpack2x16unorm(skin_binding[skin.barycentric_at + strand * skin.barycentric_stride]);
    let w = vec3<f32>(1.0 - b.x - b.y, b.x, b.y);
    let ia = skin.index_at + tri * 3u;
    let v = vec3<u32>(skin_scalp[ia], skin_scalp[ia + 1u], skin_scalp[ia + 2u]);
    let a0 = skin_rest_vertex(v.x);
    let b0 = skin_rest_vertex(v.y);
    let c0 = skin_rest_vertex(v.z);
    let a1 = skin_posed_vertex(v.x);
    let b1 = skin_posed_vertex(v.y);
    let c1 = skin_posed_vertex(v.z);
    let rotation = skin_frame(a1, b1, c1) * transpose(skin_frame(a0, b0, c0));
    let origin0 = w.x * a0 + w.y * b0 + w.z * c0;
    let origin1 = w.x * a1 + w.y * b1 + w.z * c1;
    let p = vec3<f32>(bitcast<f32>(skin_rest[r]), bitcast<f32>(skin_rest[r + 1u]), bitcast<f32>(skin_rest[r + 2u]));
    let q = origin1 + rotation * (p - origin0);
    skin_posed[r] = bitcast<u32>(q.x);
    skin_posed[r + 1u] = bitcast<u32>(q.y);
    skin_posed[r + 2u] = bitcast<u32>(q.z);
    let t = rotation * hair_oct_decode(unpack2x16unorm(skin_rest[r + 3u]));
    skin_posed[r + 3u] = pack2x16unorm(hair_oct_encode(normalize(t)));
}
