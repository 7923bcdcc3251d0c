//! Hair bound to a skinned scalp: the per-strand [`StrandBinding`] of a `HairBinding` mesh and
//! the [`Scalp`] it names, written by the baker and read by the runtime's skinning pass and its
//! CPU reference — one definition of both layouts.

use crate::asset::{BINDING_STREAMS, SCALP_STREAMS};
use crate::error::BundleError;
use crate::mesh::{ComponentType, MeshData, read_elements, read_uint};

/// Where one strand is rooted: a scalp triangle and the barycentric weights of the surface
/// point its root was bound to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrandBinding {
    /// Index of the triangle in the scalp's triangle list.
    pub triangle: u32,
    /// Weights of the triangle's second and third vertex (stored as 16-bit unorm); the first's
    /// is 1 − both.
    pub barycentric: [f32; 2],
}

impl StrandBinding {
    /// All three barycentric weights, the first vertex's first.
    pub fn weights(&self) -> [f32; 3] {
        let [b1, b2] = self.barycentric;
        [1.0 - b1 - b2, b1, b2]
    }
}

/// A `HairBinding` mesh of `bindings`, one element per strand id.
pub fn binding_mesh(bindings: &[StrandBinding]) -> Result<MeshData, BundleError> {
    let mut mesh = MeshData::new(bindings.len() as u32);
    let triangles: Vec<u8> = bindings.iter().flat_map(|b| b.triangle.to_le_bytes()).collect();
    mesh.push_raw(BINDING_STREAMS[0].name, ComponentType::U32, 1, &triangles)?;
    let weights: Vec<f32> = bindings.iter().flat_map(|b| b.barycentric).collect();
    mesh.push_normalized(BINDING_STREAMS[1].name, ComponentType::U16, 2, &weights)?;
    Ok(mesh)
}

/// The bindings of a `HairBinding` mesh (its streams checked as the kind's), or a message.
pub fn read_binding(mesh: &MeshData) -> Result<Vec<StrandBinding>, String> {
    let stream = |i: usize| {
        let s = &BINDING_STREAMS[i];
        mesh.desc.attribute(s.name).filter(|a| a.component == s.component && a.components == s.components).ok_or_else(
            || format!("a hair binding needs a `{}` stream of {:?} × {}", s.name, s.component, s.components),
        )
    };
    let (triangle, barycentric) = (stream(0)?, stream(1)?);
    let weights = read_elements(&mesh.bytes, barycentric)
        .map(|e| [ComponentType::U16.normalized(e, 0), ComponentType::U16.normalized(e, 1)]);
    Ok(read_elements(&mesh.bytes, triangle)
        .zip(weights)
        .map(|(t, barycentric)| StrandBinding { triangle: read_uint(t, ComponentType::U32), barycentric })
        .collect())
}

/// A skinned scalp in memory (see [`crate::AssetKind::Scalp`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scalp {
    /// Bind-pose positions, in the hair's frame.
    pub positions: Vec<[f32; 3]>,
    /// Up to four joints per vertex (indices into the scalp's joint list).
    pub joints: Vec<[u16; 4]>,
    /// Their weights, summing to 1 (stored as 16-bit unorm).
    pub weights: Vec<[f32; 4]>,
    /// Per vertex: the farthest any strip bound to one of its triangles lies from its root's
    /// surface point (world units).
    pub reach: Vec<f32>,
    /// Triangles, three vertex indices each.
    pub triangles: Vec<[u32; 3]>,
}

impl Scalp {
    /// The scalp as a `Scalp` mesh.
    pub fn to_mesh(&self) -> Result<MeshData, BundleError> {
        let mut mesh = MeshData::new(self.positions.len() as u32);
        mesh.push_f32(SCALP_STREAMS[0].name, 3, self.positions.as_flattened())?;
        let joints: Vec<u8> = self.joints.iter().flatten().flat_map(|j| j.to_le_bytes()).collect();
        mesh.push_raw(SCALP_STREAMS[1].name, ComponentType::U16, 4, &joints)?;
        mesh.push_normalized(SCALP_STREAMS[2].name, ComponentType::U16, 4, self.weights.as_flattened())?;
        mesh.push_f32(SCALP_STREAMS[3].name, 1, &self.reach)?;
        mesh.set_indices(self.triangles.as_flattened())?;
        Ok(mesh)
    }

    /// The scalp a `Scalp` mesh holds (its streams checked as the kind's, its indices below
    /// the vertex count), or a message.
    pub fn read(mesh: &MeshData) -> Result<Scalp, String> {
        for s in &SCALP_STREAMS {
            if !mesh.desc.attribute(s.name).is_some_and(|a| a.component == s.component && a.components == s.components)
            {
                return Err(format!("a scalp needs a `{}` stream of {:?} × {}", s.name, s.component, s.components));
            }
        }
        let positions = mesh.read_f32("position").expect("checked above");
        let weights = mesh.read_normalized("weights").expect("checked above");
        let joints_accessor = mesh.desc.attribute("joints").expect("checked above");
        let joints = read_elements(&mesh.bytes, joints_accessor)
            .map(|e| std::array::from_fn(|k| u16::from_le_bytes([e[2 * k], e[2 * k + 1]])))
            .collect();
        // The skinning pass reads the triangles as 4-byte words.
        match &mesh.desc.indices {
            Some(ix) if ix.component == ComponentType::U32 && ix.offset.is_multiple_of(4) => {}
            Some(ix) => {
                return Err(format!(
                    "a scalp needs U32 triangle indices on a 4-byte boundary, found {:?} at byte {}",
                    ix.component, ix.offset
                ));
            }
            None => return Err("a scalp needs triangle indices".into()),
        }
        let indices = mesh.read_indices().expect("checked above");
        if let Some(bad) = indices.iter().find(|&&i| i >= mesh.desc.vertex_count) {
            return Err(format!("index {bad} is not below the scalp's {} vertices", mesh.desc.vertex_count));
        }
        Ok(Scalp {
            positions: positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect(),
            joints,
            weights: weights.chunks_exact(4).map(|w| [w[0], w[1], w[2], w[3]]).collect(),
            reach: mesh.read_f32("reach").expect("checked above"),
            triangles: indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        })
    }

    /// What is wrong with this scalp and `bindings` together, for `joints` joints and
    /// `strands` strands: a triangle past the list, weights outside a triangle, a joint past
    /// the list, weights that do not sum to 1.
    pub fn check(&self, bindings: &[StrandBinding], joints: usize, strands: u32) -> Result<(), String> {
        if bindings.len() != strands as usize {
            return Err(format!("{} bindings for {strands} strands (expected one per strand)", bindings.len()));
        }
        for (s, b) in bindings.iter().enumerate() {
            if b.triangle as usize >= self.triangles.len() {
                return Err(format!(
                    "strand {s} is bound to triangle {}, past the scalp's {}",
                    b.triangle,
                    self.triangles.len()
                ));
            }
            if b.barycentric[0] + b.barycentric[1] > 1.0 + 2.0 / 65535.0 {
                return Err(format!("strand {s}: barycentric weights {:?} lie outside its triangle", b.barycentric));
            }
        }
        for (v, (j, w)) in self.joints.iter().zip(&self.weights).enumerate() {
            if let Some((&bad, _)) = j.iter().zip(w).find(|(j, w)| **w > 0.0 && **j as usize >= joints) {
                return Err(format!("scalp vertex {v} names joint {bad}, past the skin's {joints}"));
            }
            let sum: f32 = w.iter().sum();
            if (sum - 1.0).abs() > 4.0 / 65535.0 + 1e-4 {
                return Err(format!("scalp vertex {v}: joint weights sum to {sum}, expected 1"));
            }
        }
        if let Some((v, r)) = self.reach.iter().enumerate().find(|(_, r)| !(r.is_finite() && **r >= 0.0)) {
            return Err(format!("scalp vertex {v}: reach {r} must be finite and not negative"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both layouts round-trip through their meshes: integers exact, weights to a 16-bit step.
    #[test]
    fn binding_and_scalp_round_trip() {
        let bindings = [
            StrandBinding { triangle: 0, barycentric: [0.25, 0.5] },
            StrandBinding { triangle: 70_000, barycentric: [0.0, 1.0] },
        ];
        let back = read_binding(&binding_mesh(&bindings).unwrap()).unwrap();
        assert_eq!(back.iter().map(|b| b.triangle).collect::<Vec<_>>(), [0, 70_000]);
        for (a, b) in bindings.iter().zip(&back) {
            assert!((0..2).all(|k| (a.barycentric[k] - b.barycentric[k]).abs() <= 0.5 / 65535.0));
        }
        let scalp = Scalp {
            positions: vec![[0.0, 1.0, 2.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
            joints: vec![[0, 1, 0, 0], [300, 2, 1, 0], [1, 0, 0, 0]],
            weights: vec![[0.5, 0.5, 0.0, 0.0], [0.7, 0.2, 0.1, 0.0], [1.0, 0.0, 0.0, 0.0]],
            reach: vec![1.0, 2.0, 0.5],
            triangles: vec![[0, 1, 2]],
        };
        let read = Scalp::read(&scalp.to_mesh().unwrap()).unwrap();
        // 16-bit indices, which the skinning pass cannot read, are refused by name.
        let mut narrow = scalp.to_mesh().unwrap();
        let offset = narrow.bytes.len() as u64;
        narrow.bytes.extend([0u8, 0, 1, 0, 2, 0, 0, 0]);
        let ix = narrow.desc.indices.as_mut().unwrap();
        (ix.component, ix.offset, ix.stride) = (ComponentType::U16, offset, 2);
        narrow.desc.check(narrow.bytes.len() as u64).unwrap();
        let e = Scalp::read(&narrow).unwrap_err();
        assert!(e.contains("U32 triangle indices") && e.contains("U16"), "{e}");
        assert_eq!(
            (&read.positions, &read.joints, &read.reach, &read.triangles),
            (&scalp.positions, &scalp.joints, &scalp.reach, &scalp.triangles)
        );
        assert!(
            read.weights
                .iter()
                .flatten()
                .zip(scalp.weights.iter().flatten())
                .all(|(a, b)| (a - b).abs() <= 0.5 / 65535.0)
        );
        // Joint 300 is past a 3-joint skin; a 301-joint skin takes it. Joint 2, weighted second
        // at vertex 1, is past a 2-joint skin.
        assert!(read.check(&back[..1], 3, 1).unwrap_err().contains("joint 300"));
        let mut second = read.clone();
        second.joints[1] = [0, 2, 1, 0];
        assert!(second.check(&back[..1], 2, 1).unwrap_err().contains("vertex 1 names joint 2"));
        read.check(&back[..1], 301, 1).unwrap();
        assert!(read.check(&back, 301, 2).unwrap_err().contains("triangle 70000"));
        assert!(read.check(&back[..1], 301, 2).unwrap_err().contains("one per strand"));
    }
}
