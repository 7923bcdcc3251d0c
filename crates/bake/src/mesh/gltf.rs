//! A glTF 2.0 reader for what curvature and hair binding need, from a `.glb` or from a `.gltf`
//! whose buffers are `data:` URIs or files beside it: for curvature ([`load`]) the triangle
//! primitives of the file's first mesh with `POSITION` and `TEXCOORD_0`; for binding hair to a
//! scalp ([`load_skinned`]) the first skinned node's mesh with `POSITION`, `JOINTS_0` and
//! `WEIGHTS_0` and its skin's joint names. Node transforms are ignored (the mesh's own space, as
//! with OBJ; skinning positions are in it), and so are materials, normals, animations and every
//! other extension of the format.
//!
//! glTF repeats a position for every (position, normal, texture coordinate) combination; the
//! reader welds bit-identical positions back together, so curvature is shared across seams as it
//! is for OBJ. Texture coordinates are used as stored: glTF's origin is the top-left corner, the
//! same as texture space here.
//!
//! Every count, offset and stride is checked against the bytes actually present before anything
//! is allocated from it, and the file plus its buffers may not exceed [`MeshLimits::max_bytes`].

use std::collections::HashMap;
use std::path::{Component, Path};

use glam::{DVec2, DVec3};
use serde::Deserialize;

use super::{Mesh, MeshLimits};
use crate::error::BakeError;

const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// True when `bytes` start like a binary glTF file.
pub fn is_glb(bytes: &[u8]) -> bool {
    bytes.starts_with(GLB_MAGIC)
}

#[derive(Deserialize)]
struct Root {
    #[serde(default)]
    buffers: Vec<Buffer>,
    #[serde(default, rename = "bufferViews")]
    views: Vec<View>,
    #[serde(default)]
    accessors: Vec<Accessor>,
    #[serde(default)]
    meshes: Vec<MeshDef>,
    #[serde(default)]
    nodes: Vec<Node>,
    #[serde(default)]
    skins: Vec<Skin>,
}

#[derive(Deserialize)]
struct Node {
    name: Option<String>,
    mesh: Option<usize>,
    skin: Option<usize>,
}

#[derive(Deserialize)]
struct Skin {
    joints: Vec<usize>,
}

#[derive(Deserialize)]
struct Buffer {
    uri: Option<String>,
    #[serde(rename = "byteLength")]
    byte_length: u64,
}

#[derive(Deserialize)]
struct View {
    buffer: usize,
    #[serde(default, rename = "byteOffset")]
    byte_offset: u64,
    #[serde(rename = "byteLength")]
    byte_length: u64,
    #[serde(rename = "byteStride")]
    byte_stride: Option<u64>,
}

#[derive(Deserialize)]
struct Accessor {
    #[serde(rename = "bufferView")]
    view: Option<usize>,
    #[serde(default, rename = "byteOffset")]
    byte_offset: u64,
    #[serde(rename = "componentType")]
    component_type: u32,
    #[serde(default)]
    normalized: bool,
    count: u64,
    #[serde(rename = "type")]
    kind: String,
    sparse: Option<serde_json::Value>,
}

#[derive(Deserialize)]
struct MeshDef {
    primitives: Vec<Primitive>,
}

#[derive(Deserialize)]
struct Primitive {
    attributes: HashMap<String, usize>,
    indices: Option<usize>,
    mode: Option<u32>,
}

/// The parsed JSON of a `.glb` or `.gltf` file and its buffers.
fn open(path: &Path, limits: MeshLimits) -> Result<(Root, Vec<Vec<u8>>), BakeError> {
    let bytes = super::read_limited(path, limits.max_bytes, "glTF size")?;
    let bad = |place: Option<String>, m: String| BakeError::input(path, place, m);
    let (json, bin) = if is_glb(&bytes) { split_glb(&bytes).map_err(|m| bad(None, m))? } else { (&bytes[..], None) };
    let root: Root = serde_json::from_slice(json).map_err(|e| {
        bad(Some(format!("line {}, column {}", e.line(), e.column())), format!("invalid glTF JSON: {e}"))
    })?;
    let mut budget = limits.max_bytes.saturating_sub(bytes.len() as u64);
    let mut buffers = Vec::with_capacity(root.buffers.len().min(64));
    for (i, b) in root.buffers.iter().enumerate() {
        let place = || Some(format!("buffer {i}"));
        let data = match (&b.uri, bin, i) {
            (None, Some(bin), 0) => bin.to_vec(),
            (None, _, _) => return Err(bad(place(), "has no uri and is not the GLB's binary chunk".into())),
            (Some(uri), _, _) => buffer_from_uri(path, uri, &mut budget).map_err(|m| bad(place(), m))?,
        };
        if (data.len() as u64) < b.byte_length {
            let found = data.len();
            return Err(bad(place(), format!("expected {} bytes, found {found}", b.byte_length)));
        }
        buffers.push(data);
    }
    Ok((root, buffers))
}

/// Reads a `.glb` or `.gltf` file.
pub fn load(path: &Path, limits: MeshLimits) -> Result<Mesh, BakeError> {
    let bad = |place: Option<String>, m: String| BakeError::input(path, place, m);
    let (root, buffers) = open(path, limits)?;
    let mesh = root.meshes.first().ok_or_else(|| bad(None, "expected at least one mesh".into()))?;
    let doc = Document { root: &root, buffers: &buffers };
    let mut out =
        Mesh { positions: Vec::new(), vertex_position: Vec::new(), vertex_uv: Vec::new(), triangles: Vec::new() };
    let mut welded: HashMap<[u64; 3], u32> = HashMap::new();
    for (p, prim) in mesh.primitives.iter().enumerate() {
        let place = |what: &str| Some(format!("mesh 0, primitive {p}{what}"));
        if prim.mode.unwrap_or(4) != 4 {
            let mode = prim.mode.unwrap_or(4);
            return Err(bad(place(""), format!("expected triangles (mode 4), found mode {mode}")));
        }
        let attribute = |name: &str, why: &str| {
            prim.attributes.get(name).copied().ok_or_else(|| bad(place(""), format!("has no {name}; {why}")))
        };
        let positions =
            doc.read(attribute("POSITION", "curvature needs positions")?, "VEC3").map_err(|m| bad(place(""), m))?;
        let uvs = doc.read(attribute("TEXCOORD_0", "curvature needs UVs")?, "VEC2").map_err(|m| bad(place(""), m))?;
        let count = positions.len() / 3;
        if uvs.len() / 2 != count {
            return Err(bad(place(""), format!("POSITION has {count} vertices but TEXCOORD_0 has {}", uvs.len() / 2)));
        }
        let base = out.vertex_uv.len() as u64;
        if base + count as u64 > u32::MAX as u64 {
            return Err(bad(place(""), "more than 4 billion vertices".into()));
        }
        for (pos, uv) in positions.chunks_exact(3).zip(uvs.chunks_exact(2)) {
            let key = [pos[0].to_bits(), pos[1].to_bits(), pos[2].to_bits()];
            let next = out.positions.len() as u32;
            let index = *welded.entry(key).or_insert(next);
            if index == next {
                out.positions.push(DVec3::new(pos[0], pos[1], pos[2]));
            }
            out.vertex_position.push(index);
            out.vertex_uv.push(DVec2::new(uv[0], uv[1]));
        }
        let triangles = doc.triangles(prim, count).map_err(|m| bad(place(" indices"), m))?;
        out.triangles.extend(triangles.iter().map(|t| t.map(|i| (base + i as u64) as u32)));
    }
    if out.triangles.is_empty() {
        return Err(bad(Some("mesh 0".into()), "expected at least one triangle".into()));
    }
    Ok(out)
}

/// A skinned triangle mesh: what hair is bound to.
#[derive(Clone, Debug, PartialEq)]
pub struct SkinnedMesh {
    /// Bind-pose positions (the mesh's own space).
    pub positions: Vec<[f32; 3]>,
    /// Four joints per vertex, indices into `joint_names`.
    pub joints: Vec<[u16; 4]>,
    /// Their weights, normalized to sum to 1.
    pub weights: Vec<[f32; 4]>,
    /// Triangles over the vertices.
    pub triangles: Vec<[u32; 3]>,
    /// The skin's joints in its order: the nodes' names (`node N` for a node without one).
    pub joint_names: Vec<String>,
}

/// Reads the skinned mesh of a `.glb` or `.gltf`: the mesh of the first node that has both a
/// mesh and a skin, with `POSITION`, `JOINTS_0` and `WEIGHTS_0` on every primitive. Positions are
/// the mesh's own (bind-pose) space, as glTF skinning uses them; node transforms are ignored.
pub fn load_skinned(path: &Path, limits: MeshLimits) -> Result<SkinnedMesh, BakeError> {
    let bad = |place: Option<String>, m: String| BakeError::input(path, place, m);
    let (root, buffers) = open(path, limits)?;
    let (node, mesh_index, skin_index) = root
        .nodes
        .iter()
        .enumerate()
        .find_map(|(n, node)| Some((n, node.mesh?, node.skin?)))
        .ok_or_else(|| bad(None, "expected a node with a mesh and a skin (a skinned scalp)".into()))?;
    let skin = root
        .skins
        .get(skin_index)
        .ok_or_else(|| bad(Some(format!("node {node}")), format!("skin {skin_index} does not exist")))?;
    if skin.joints.is_empty() || skin.joints.len() > u16::MAX as usize {
        let n = skin.joints.len();
        return Err(bad(Some(format!("skin {skin_index}")), format!("expected 1 to 65535 joints, found {n}")));
    }
    let joint_names = skin
        .joints
        .iter()
        .map(|&j| match root.nodes.get(j) {
            Some(n) => Ok(n.name.clone().unwrap_or_else(|| format!("node {j}"))),
            None => Err(bad(Some(format!("skin {skin_index}")), format!("joint node {j} does not exist"))),
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mesh = root
        .meshes
        .get(mesh_index)
        .ok_or_else(|| bad(Some(format!("node {node}")), format!("mesh {mesh_index} does not exist")))?;
    let doc = Document { root: &root, buffers: &buffers };
    let mut out = SkinnedMesh {
        positions: Vec::new(),
        joints: Vec::new(),
        weights: Vec::new(),
        triangles: Vec::new(),
        joint_names,
    };
    for (p, prim) in mesh.primitives.iter().enumerate() {
        let place = |what: &str| Some(format!("mesh {mesh_index}, primitive {p}{what}"));
        let mode = prim.mode.unwrap_or(4);
        if mode != 4 {
            return Err(bad(place(""), format!("expected triangles (mode 4), found mode {mode}")));
        }
        let read = |name: &str, kind: &str| {
            let a = prim
                .attributes
                .get(name)
                .copied()
                .ok_or_else(|| bad(place(""), format!("has no {name}; binding hair needs a skinned mesh")))?;
            doc.read(a, kind).map_err(|m| bad(place(&format!(" {name}")), m))
        };
        let positions = read("POSITION", "VEC3")?;
        let (joints, weights) = (read("JOINTS_0", "VEC4")?, read("WEIGHTS_0", "VEC4")?);
        let count = positions.len() / 3;
        if joints.len() / 4 != count || weights.len() / 4 != count {
            return Err(bad(place(""), format!("POSITION, JOINTS_0 and WEIGHTS_0 must have {count} elements each")));
        }
        let base = out.positions.len() as u64;
        if base + count as u64 > u32::MAX as u64 {
            return Err(bad(place(""), "more than 4 billion vertices".into()));
        }
        for (v, ((pos, j), w)) in
            positions.chunks_exact(3).zip(joints.chunks_exact(4)).zip(weights.chunks_exact(4)).enumerate()
        {
            let sum: f64 = w.iter().sum();
            if sum.is_nan() || sum <= 0.0 || w.iter().any(|&x| x < 0.0) {
                return Err(bad(
                    place(&format!(" vertex {v}")),
                    format!("joint weights {w:?} must be ≥ 0 with a positive sum"),
                ));
            }
            if let Some(&bad_joint) =
                j.iter().zip(w).find(|(j, w)| **w > 0.0 && **j as usize >= out.joint_names.len()).map(|(j, _)| j)
            {
                return Err(bad(
                    place(&format!(" vertex {v}")),
                    format!("names joint {bad_joint}, but skin {skin_index} has {}", out.joint_names.len()),
                ));
            }
            out.positions.push([pos[0] as f32, pos[1] as f32, pos[2] as f32]);
            out.joints.push(std::array::from_fn(|k| if w[k] > 0.0 { j[k] as u16 } else { 0 }));
            out.weights.push(std::array::from_fn(|k| (w[k] / sum) as f32));
        }
        let triangles = doc.triangles(prim, count).map_err(|m| bad(place(" indices"), m))?;
        out.triangles.extend(triangles.iter().map(|t| t.map(|i| (base + i as u64) as u32)));
    }
    if out.triangles.is_empty() {
        return Err(bad(Some(format!("mesh {mesh_index}")), "expected at least one triangle".into()));
    }
    Ok(out)
}

/// The buffer files a `.gltf` names beside itself (for input hashing and `rerun-if-changed`);
/// empty for a GLB, and for a file that does not parse (reading it reports why).
pub fn external_files(path: &Path) -> Vec<std::path::PathBuf> {
    #[derive(Deserialize)]
    struct Buffers {
        #[serde(default)]
        buffers: Vec<Buffer>,
    }
    if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("gltf")) {
        return Vec::new();
    }
    let Ok(bytes) = super::read_limited(path, MeshLimits::default().max_bytes, "glTF size") else { return Vec::new() };
    let Ok(root) = serde_json::from_slice::<Buffers>(&bytes) else { return Vec::new() };
    let dir = path.parent().unwrap_or(Path::new("."));
    root.buffers.iter().filter_map(|b| b.uri.as_deref().and_then(local_file)).map(|file| dir.join(file)).collect()
}

/// A buffer `uri` naming a file beside the glTF: a relative path of plain names (no scheme, no
/// `..`, not absolute), so a file cannot make the baker read outside its directory.
fn local_file(uri: &str) -> Option<&Path> {
    let path = Path::new(uri);
    (!uri.contains(':') && path.components().all(|c| matches!(c, Component::Normal(_)))).then_some(path)
}

/// The JSON chunk and the optional binary chunk of a GLB.
fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), String> {
    let word = |at: usize| bytes.get(at..at + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
    let version = word(4).ok_or("truncated GLB header")?;
    if version != 2 {
        return Err(format!("expected GLB version 2, found {version}"));
    }
    let total = word(8).ok_or("truncated GLB header")? as usize;
    if total > bytes.len() {
        return Err(format!("the GLB header says {total} bytes, the file has {}", bytes.len()));
    }
    let mut chunks = Vec::new();
    let mut at = 12;
    while at + 8 <= total {
        let (len, kind) = (word(at).unwrap_or(0) as usize, word(at + 4).unwrap_or(0));
        let data = bytes.get(at + 8..(at + 8).saturating_add(len)).filter(|_| at + 8 + len <= total);
        let data = data.ok_or_else(|| format!("chunk at byte {at} ({len} bytes) runs past the file"))?;
        chunks.push((kind, data));
        at += 8 + len;
    }
    match chunks.as_slice() {
        [(CHUNK_JSON, json), rest @ ..] => Ok((json, rest.iter().find(|(k, _)| *k == CHUNK_BIN).map(|(_, d)| *d))),
        _ => Err("expected the JSON chunk first".into()),
    }
}

/// The bytes of a buffer `uri`: a base64 `data:` URI, or a file beside the glTF (a relative path
/// that stays in its directory). `budget` is what the limits still allow, reduced by what is read.
fn buffer_from_uri(gltf: &Path, uri: &str, budget: &mut u64) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, encoded) = rest.split_once(";base64,").ok_or("expected a base64 data URI")?;
        if encoded.len() as u64 / 4 * 3 > *budget {
            return Err("data URI exceeds the size limit".into());
        }
        let data = base64(encoded)?;
        *budget -= data.len() as u64;
        return Ok(data);
    }
    let relative = local_file(uri)
        .ok_or_else(|| format!("buffer uri {uri:?} must be a data: URI or a file name beside the glTF"))?;
    let file = gltf.parent().unwrap_or(Path::new(".")).join(relative);
    let len = hikage_bundle::files::regular_metadata(&file).map_err(|e| format!("{}: {e}", file.display()))?.len();
    if len > *budget {
        return Err(format!("{} ({len} bytes) exceeds the size limit", file.display()));
    }
    let data = hikage_bundle::files::read_limited(&file, *budget, "buffer size").map_err(|e| e.to_string())?;
    *budget -= data.len() as u64;
    Ok(data)
}

/// Decodes standard base64 (padding optional).
fn base64(text: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let (mut acc, mut bits) = (0u32, 0);
    for (i, c) in text.bytes().enumerate() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            b'=' => break,
            _ => return Err(format!("invalid base64 character at {i}")),
        };
        acc = (acc << 6) | v as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
        }
    }
    Ok(out)
}

/// The parsed JSON with its buffers.
struct Document<'a> {
    root: &'a Root,
    buffers: &'a [Vec<u8>],
}

impl Document<'_> {
    /// The triangles of primitive `prim` of `count` vertices: its index accessor, or its
    /// vertices in order, each index checked below `count`.
    fn triangles(&self, prim: &Primitive, count: usize) -> Result<Vec<[u32; 3]>, String> {
        let indices: Vec<u64> = match prim.indices {
            Some(a) => self.read(a, "SCALAR")?.into_iter().map(|i| i as u64).collect(),
            None => (0..count as u64).collect(),
        };
        if !indices.len().is_multiple_of(3) {
            return Err(format!("expected a multiple of 3 indices, found {}", indices.len()));
        }
        indices
            .chunks_exact(3)
            .enumerate()
            .map(|(t, tri)| match tri.iter().find(|&&i| i >= count as u64) {
                Some(&i) => Err(format!("triangle {t} names vertex {i}, but there are {count}")),
                None => Ok(std::array::from_fn(|k| tri[k] as u32)),
            })
            .collect()
    }

    /// Accessor `index`, which must have type `kind`, as f64 components (normalized integers
    /// mapped to [0, 1]; index accessors as plain integers).
    fn read(&self, index: usize, kind: &str) -> Result<Vec<f64>, String> {
        let a = self.root.accessors.get(index).ok_or_else(|| format!("accessor {index} does not exist"))?;
        let at = |m: String| format!("accessor {index}: {m}");
        if a.kind != kind {
            return Err(at(format!("expected type {kind}, found {}", a.kind)));
        }
        if a.sparse.is_some() {
            return Err(at("sparse accessors are not supported".into()));
        }
        let components = match kind {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC4" => 4,
            _ => 3,
        };
        let size = match (kind, a.component_type, a.normalized) {
            ("SCALAR", 5121, false) => 1,
            ("SCALAR", 5123, false) => 2,
            ("SCALAR", 5125, false) => 4,
            ("VEC2", 5121, true) => 1,
            ("VEC2", 5123, true) => 2,
            // JOINTS_0 (integers) and WEIGHTS_0 (normalized).
            ("VEC4", 5121, _) => 1,
            ("VEC4", 5123, _) => 2,
            (_, 5126, _) if kind != "SCALAR" => 4,
            (_, t, n) => return Err(at(format!("component type {t} (normalized: {n}) is not supported for {kind}"))),
        };
        let view_index = a.view.ok_or_else(|| at("has no bufferView".into()))?;
        let view =
            self.root.views.get(view_index).ok_or_else(|| at(format!("bufferView {view_index} does not exist")))?;
        let buffer =
            self.buffers.get(view.buffer).ok_or_else(|| at(format!("buffer {} does not exist", view.buffer)))?;
        let element = components * size;
        let stride = view.byte_stride.unwrap_or(element as u64);
        if stride < element as u64 {
            return Err(at(format!("byteStride {stride} is smaller than an element ({element} bytes)")));
        }
        let view_end = view.byte_offset.checked_add(view.byte_length).filter(|&e| e <= buffer.len() as u64);
        view_end.ok_or_else(|| at(format!("bufferView {view_index} runs past its buffer")))?;
        let last = a.count.checked_sub(1).map_or(Some(0), |n| n.checked_mul(stride));
        last.and_then(|x| x.checked_add(a.byte_offset)?.checked_add(element as u64))
            .filter(|&n| n <= view.byte_length)
            .ok_or_else(|| at(format!("{} elements do not fit in bufferView {view_index}", a.count)))?;
        let start = view.byte_offset as usize + a.byte_offset as usize;
        let mut out = Vec::with_capacity(a.count as usize * components);
        for e in 0..a.count as usize {
            let base = start + e * stride as usize;
            for c in 0..components {
                let b = &buffer[base + c * size..base + (c + 1) * size];
                let v = match (size, a.component_type) {
                    (1, _) => b[0] as f64,
                    (2, _) => u16::from_le_bytes([b[0], b[1]]) as f64,
                    (4, 5126) => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                };
                let v = match (a.normalized, size) {
                    (true, 1) => v / 255.0,
                    (true, 2) => v / 65535.0,
                    _ => v,
                };
                if !v.is_finite() {
                    return Err(at(format!("element {e} is not finite")));
                }
                out.push(v);
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_decodes_the_rfc_examples() {
        for (text, plain) in [("", ""), ("Zg==", "f"), ("Zm8=", "fo"), ("Zm9v", "foo"), ("Zm9vYmFy", "foobar")] {
            assert_eq!(base64(text).unwrap(), plain.as_bytes(), "{text}");
        }
        assert!(base64("Zm9v!").is_err());
    }
}
