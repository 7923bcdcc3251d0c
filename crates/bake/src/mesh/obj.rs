//! A Wavefront OBJ reader for what curvature needs: `v`, `vt` and `f` (polygons are fanned
//! into triangles; `vn`, groups, materials and other statements are ignored). Every face
//! corner must name a texture coordinate.

use std::path::Path;

use glam::{DVec2, DVec3};

use super::{Mesh, MeshLimits};
use crate::error::BakeError;

/// Reads an OBJ file.
pub fn load(path: &Path, limits: MeshLimits) -> Result<Mesh, BakeError> {
    let bytes = super::read_limited(path, limits.max_bytes, "OBJ size")?;
    let text = std::str::from_utf8(&bytes)
        .map_err(|e| BakeError::input(path, Some(format!("byte {}", e.valid_up_to())), "expected UTF-8 text"))?;
    parse(text, path)
}

/// Parses OBJ text; `path` names the file in errors (`path: line N: …`).
pub fn parse(text: &str, path: &Path) -> Result<Mesh, BakeError> {
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    let mut mesh =
        Mesh { positions: Vec::new(), vertex_position: Vec::new(), vertex_uv: Vec::new(), triangles: Vec::new() };
    let mut corners: std::collections::HashMap<(u32, u32), u32> = std::collections::HashMap::new();
    for (n, line) in text.lines().enumerate() {
        let place = || Some(format!("line {}", n + 1));
        let bad = |m: String| BakeError::input(path, place(), m);
        let mut parts = line.split_whitespace();
        match parts.next() {
            Some("v") => positions.push(DVec3::from(numbers::<3>(&mut parts).map_err(bad)?)),
            Some("vt") => {
                let [u, v] = numbers::<2>(&mut parts).map_err(bad)?;
                uvs.push(DVec2::new(u, v));
            }
            Some("f") => {
                let mut face = Vec::new();
                for corner in parts {
                    let mut it = corner.split('/');
                    let vi = index(it.next(), positions.len(), "vertex").map_err(bad)?;
                    let ti = match it.next() {
                        Some(t) if !t.is_empty() => index(Some(t), uvs.len(), "texture coordinate").map_err(bad)?,
                        _ => {
                            return Err(bad(format!(
                                "face corner {corner:?} has no texture coordinate; curvature needs UVs"
                            )));
                        }
                    };
                    let next = corners.len() as u32;
                    let v = *corners.entry((vi, ti)).or_insert(next);
                    if v == next {
                        mesh.vertex_position.push(vi);
                        mesh.vertex_uv.push(uvs[ti as usize]);
                    }
                    face.push(v);
                }
                if face.len() < 3 {
                    return Err(bad(format!("expected a face of 3 or more corners, found {}", face.len())));
                }
                for i in 1..face.len() - 1 {
                    mesh.triangles.push([face[0], face[i], face[i + 1]]);
                }
            }
            _ => {}
        }
    }
    if mesh.triangles.is_empty() {
        return Err(BakeError::input(path, None, "expected at least one face"));
    }
    mesh.positions = positions;
    Ok(mesh)
}

fn numbers<const N: usize>(parts: &mut std::str::SplitWhitespace) -> Result<[f64; N], String> {
    let mut out = [0.0; N];
    for o in out.iter_mut() {
        let t = parts.next().ok_or_else(|| format!("expected {N} numbers"))?;
        *o = t.parse::<f64>().map_err(|_| format!("expected a number, found {t:?}"))?;
        if !o.is_finite() {
            return Err(format!("expected a finite number, found {t}"));
        }
    }
    Ok(out)
}

/// A 1-based (or negative, relative) OBJ index into a list of `len` items, as a 0-based index.
fn index(token: Option<&str>, len: usize, what: &str) -> Result<u32, String> {
    let t = token.ok_or_else(|| format!("expected a {what} index"))?;
    let i: i64 = t.parse().map_err(|_| format!("expected a {what} index, found {t:?}"))?;
    let resolved = if i < 0 { len as i64 + i } else { i - 1 };
    if resolved < 0 || resolved >= len as i64 {
        return Err(format!("{what} index {i} is out of range (1 to {len} defined so far)"));
    }
    Ok(resolved as u32)
}
