//! Curvature of analytic surfaces: a sphere (κ1 = κ2 = 1/r) and a cylinder (1/r, 0, the first
//! principal direction around it), plus the errors of bad meshes.

use std::path::Path;

use hikage_bake::curvature::{CurvatureError, compute};
use hikage_bake::mesh::{self, obj};
use hikage_devkit::synth;

#[test]
fn sphere_has_equal_principal_curvatures_of_one_over_r() {
    let r = 2.0;
    let mesh = obj::parse(&synth::uv_sphere_obj(r, 64, 32, 1.0), Path::new("sphere.obj")).unwrap();
    let c = compute(&mesh).unwrap();
    let mut worst: f64 = 0.0;
    for (v, vc) in c.iter().enumerate() {
        let p = mesh.positions[mesh.vertex_position[v] as usize];
        if p.y.abs() > 0.9 * r {
            continue; // the poles' fans are not a regular grid
        }
        worst = worst.max((vc.k1 - 1.0 / r).abs()).max((vc.k2 - 1.0 / r).abs());
        assert!((vc.normal - p / r).length() < 0.01, "normals point outward");
    }
    // A quadric fit over the 2-ring: within 2% on this 64×32 grid (cells up to 3:1 near ±0.9 r).
    assert!(worst < 0.02 / r, "worst curvature error {worst} for 1/r = {}", 1.0 / r);
}

#[test]
fn cylinder_has_one_over_r_around_and_zero_along() {
    let r = 3.0;
    let mesh = obj::parse(&synth::cylinder_obj(r, 10.0, 96, 24), Path::new("cylinder.obj")).unwrap();
    let c = compute(&mesh).unwrap();
    for (v, vc) in c.iter().enumerate() {
        let p = mesh.positions[mesh.vertex_position[v] as usize];
        if p.y < 1.0 || p.y > 9.0 {
            continue; // open ends have one-sided neighbourhoods
        }
        assert!((vc.k1 - 1.0 / r).abs() < 0.01 / r, "k1 {} at {p}", vc.k1);
        assert!(vc.k2.abs() < 0.01 / r, "k2 {} at {p}", vc.k2);
        // u runs around the cylinder: the first principal direction is ±u in the texture frame.
        assert!(vc.dir1_uv.x.abs() > 0.999 && vc.dir2_uv.y.abs() > 0.999, "{:?} {:?}", vc.dir1_uv, vc.dir2_uv);
    }
}

/// A torus, whose principal curvatures differ: 1/r across the tube (the first direction, along
/// v) and cos ψ / (R + r cos ψ) along the ring. The texture frame P_u, P_v is the exact
/// derivative of the parameterisation.
#[test]
fn torus_has_its_two_principal_curvatures_and_texture_frame() {
    let (big, small) = (100.0f32, 40.0f32);
    let dir = std::env::temp_dir().join(format!("hikage-torus-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("torus.glb");
    std::fs::write(&path, synth::torus_glb(big, small, 64, 32, (4.0, 1.0))).unwrap();
    let mesh = mesh::load(&path, mesh::MeshLimits::default()).unwrap();
    let c = compute(&mesh).unwrap();
    let tau = std::f64::consts::TAU;
    let (mut worst_k, mut worst_frame) = (0.0f64, 0.0f64);
    for (v, vc) in c.iter().enumerate() {
        let p = mesh.positions[mesh.vertex_position[v] as usize];
        let uv = mesh.vertex_uv[v];
        let psi = tau * uv.y;
        if psi.cos() < 0.5 {
            continue; // the inner half is saddle-shaped; check where both are positive
        }
        let (r, rr) = (small as f64, big as f64 + small as f64 * psi.cos());
        worst_k = worst_k.max((vc.k1 - 1.0 / r).abs() * r).max((vc.k2 - psi.cos() / rr).abs() * rr);
        // First direction across the tube: along v, so its dot product with the unit +v is ±1.
        assert!(vc.dir1_uv.y.abs() > 0.99, "{:?} at {p}", vc.dir1_uv);
        // P_u = dP/du: the ring's tangent, 2π(R + r cos ψ)/4 long; P_v: the tube's, 2πr long.
        let phi = tau * uv.x / 4.0;
        let pu = glam::DVec3::new(-phi.sin(), 0.0, -phi.cos()) * (rr * tau / 4.0);
        let pv = glam::DVec3::new(-psi.sin() * phi.cos(), psi.cos(), psi.sin() * phi.sin()) * (r * tau);
        worst_frame = worst_frame.max((vc.pu - pu).length() / pu.length()).max((vc.pv - pv).length() / pv.length());
    }
    std::fs::remove_dir_all(&dir).unwrap();
    // 32 segments around the tube: the quadric fit over the 2-ring (points 11° and 22° around)
    // reads the circle's quartic term as curvature, 3.7% high across the tube.
    assert!(worst_k < 0.05, "worst relative curvature error {worst_k}");
    assert!(worst_frame < 0.01, "worst relative frame error {worst_frame}");
}

#[test]
fn bad_meshes_are_refused_with_place() {
    let no_uv = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let e = obj::parse(no_uv, Path::new("m.obj")).unwrap_err().to_string();
    assert!(e.contains("m.obj: line 4") && e.contains("texture coordinate"), "{e}");
    let out_of_range = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 4/1\n";
    let e = obj::parse(out_of_range, Path::new("m.obj")).unwrap_err().to_string();
    assert!(e.contains("line 5") && e.contains("vertex index 4 is out of range"), "{e}");
    let nan = "v 0 nan 0\n";
    assert!(obj::parse(nan, Path::new("m.obj")).unwrap_err().to_string().contains("line 1"));
    let degenerate = "v 0 0 0\nv 1 0 0\nv 2 0 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
    let mesh = obj::parse(degenerate, Path::new("m.obj")).unwrap();
    assert_eq!(compute(&mesh).unwrap_err(), CurvatureError::Degenerate { triangle: 0 });
    let flat_uv = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 2 0\nf 1/1 2/2 3/3\n";
    let mesh = obj::parse(flat_uv, Path::new("m.obj")).unwrap();
    assert_eq!(compute(&mesh).unwrap_err(), CurvatureError::DegenerateUv { triangle: 0 });
    assert!(obj::parse("# nothing\n", Path::new("m.obj")).is_err());
}

/// The sphere of the OBJ test as glTF vertices (one per (position, uv) corner, as glTF stores
/// them), interleaved `[x y z u v]` f32, with u32 triangle indices.
fn sphere_as_gltf_streams(r: f64) -> (Vec<u8>, Vec<u8>, usize, usize) {
    let mesh = obj::parse(&synth::uv_sphere_obj(r, 64, 32, 1.0), Path::new("sphere.obj")).unwrap();
    let mut vertices = Vec::new();
    for (v, uv) in mesh.vertex_uv.iter().enumerate() {
        let p = mesh.positions[mesh.vertex_position[v] as usize];
        for x in [p.x, p.y, p.z, uv.x, uv.y] {
            vertices.extend_from_slice(&(x as f32).to_le_bytes());
        }
    }
    let indices: Vec<u8> = mesh.triangles.iter().flatten().flat_map(|i| i.to_le_bytes()).collect();
    (vertices, indices, mesh.vertex_uv.len(), mesh.triangles.len() * 3)
}

/// glTF JSON for the streams above, the buffer given by `uri` (`None`: the GLB chunk).
fn sphere_gltf_json(
    uri: Option<String>,
    vertex_bytes: usize,
    index_bytes: usize,
    vertices: usize,
    indices: usize,
) -> String {
    let uri = uri.map_or(String::new(), |u| format!(r#""uri": "{u}", "#));
    format!(
        r#"{{"asset": {{"version": "2.0"}},
  "buffers": [{{{uri}"byteLength": {total}}}],
  "bufferViews": [{{"buffer": 0, "byteLength": {vertex_bytes}, "byteStride": 20}},
                  {{"buffer": 0, "byteOffset": {vertex_bytes}, "byteLength": {index_bytes}}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": {vertices}, "type": "VEC3"}},
                {{"bufferView": 0, "byteOffset": 12, "componentType": 5126, "count": {vertices}, "type": "VEC2"}},
                {{"bufferView": 1, "componentType": 5125, "count": {indices}, "type": "SCALAR"}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "indices": 2}}]}}]}}"#,
        total = vertex_bytes + index_bytes
    )
}

fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut json = json.as_bytes().to_vec();
    json.resize(json.len().next_multiple_of(4), b' ');
    let mut bin = bin.to_vec();
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = b"glTF".to_vec();
    for word in [2, total as u32, json.len() as u32, 0x4E4F_534A] {
        out.extend_from_slice(&word.to_le_bytes());
    }
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let n = chunk.iter().enumerate().fold(0u32, |acc, (i, &b)| acc | (b as u32) << (16 - 8 * i));
        for i in 0..4 {
            out.push(if i <= chunk.len() { ALPHABET[(n >> (18 - 6 * i) & 63) as usize] as char } else { '=' });
        }
    }
    out
}

#[test]
fn gltf_meshes_give_the_curvature_of_the_same_obj_mesh() {
    let r = 2.0;
    let reference = {
        let mesh = obj::parse(&synth::uv_sphere_obj(r, 64, 32, 1.0), Path::new("sphere.obj")).unwrap();
        compute(&mesh).unwrap()
    };
    let (vertices, indices, nv, ni) = sphere_as_gltf_streams(r);
    let bin: Vec<u8> = [vertices.clone(), indices.clone()].concat();
    let dir = std::env::temp_dir().join(format!("hikage-gltf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let json = |uri| sphere_gltf_json(uri, vertices.len(), indices.len(), nv, ni);
    std::fs::write(dir.join("sphere.glb"), glb(&json(None), &bin)).unwrap();
    std::fs::write(dir.join("sphere.bin"), &bin).unwrap();
    std::fs::write(dir.join("external.gltf"), json(Some("sphere.bin".into()))).unwrap();
    let data_uri = format!("data:application/octet-stream;base64,{}", base64(&bin));
    std::fs::write(dir.join("embedded.gltf"), json(Some(data_uri))).unwrap();
    for name in ["sphere.glb", "external.gltf", "embedded.gltf"] {
        let mesh = mesh::load(&dir.join(name), mesh::MeshLimits::default()).unwrap();
        // glTF repeats positions at the seam; welded back, the vertices match the OBJ's.
        let c = compute(&mesh).unwrap();
        assert_eq!(c.len(), reference.len(), "{name}");
        for (a, b) in c.iter().zip(&reference) {
            // Positions went through f32.
            assert!((a.k1 - b.k1).abs() < 1e-4 && (a.k2 - b.k2).abs() < 1e-4, "{name}: {a:?} vs {b:?}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_gltf_is_refused_with_place() {
    let (vertices, indices, nv, ni) = sphere_as_gltf_streams(1.0);
    let bin: Vec<u8> = [vertices.clone(), indices.clone()].concat();
    let json = sphere_gltf_json(None, vertices.len(), indices.len(), nv, ni);
    let dir = std::env::temp_dir().join(format!("hikage-bad-gltf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let error = |name: &str, bytes: Vec<u8>| {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        mesh::load(&path, mesh::MeshLimits::default()).unwrap_err().to_string()
    };
    let e = error("no_uv.glb", glb(&json.replace(r#", "TEXCOORD_0": 1"#, ""), &bin));
    assert!(e.contains("no_uv.glb") && e.contains("primitive 0") && e.contains("TEXCOORD_0"), "{e}");
    let e = error(
        "count.glb",
        glb(&json.replace(&format!(r#""count": {nv}, "type": "VEC2""#), r#""count": 99999999, "type": "VEC2""#), &bin),
    );
    assert!(e.contains("accessor 1") && e.contains("do not fit"), "{e}");
    let mut wild = indices.clone();
    wild[..4].copy_from_slice(&(nv as u32 + 5).to_le_bytes());
    let e = error("index.glb", glb(&json, &[vertices.clone(), wild].concat()));
    assert!(e.contains("triangle 0") && e.contains(&format!("vertex {}", nv + 5)), "{e}");
    let e = error(
        "escape.gltf",
        sphere_gltf_json(Some("../secret.bin".into()), vertices.len(), indices.len(), nv, ni).into_bytes(),
    );
    assert!(e.contains("buffer 0") && e.contains("beside the glTF"), "{e}");
    let mut truncated = glb(&json, &bin);
    truncated.truncate(truncated.len() - 100);
    let e = error("truncated.glb", truncated);
    assert!(e.contains("truncated.glb") && e.contains("bytes"), "{e}");
    let e = error("lines.glb", glb(&json.replace(r#""indices": 2"#, r#""indices": 2, "mode": 1"#), &bin));
    assert!(e.contains("mode 1"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}
