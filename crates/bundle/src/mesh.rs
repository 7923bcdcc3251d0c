//! Mesh payloads: one little-endian buffer holding vertex streams and an optional index
//! stream, each described by an accessor the way glTF describes them (byte offset, byte
//! stride, component type, components per element, element count).

use serde::{Deserialize, Serialize};

use crate::error::BundleError;
use crate::texture::Supercompression;

/// Scalar type of an accessor's components.
///
/// In vertex streams the 8- and 16-bit types are normalized as glTF's `normalized` accessors
/// are: `U8`/`U16` to 0–1 (c / 255, c / 65535), `I8`/`I16` to −1–1 (max(c / 127, −1),
/// max(c / 32767, −1)), unless a kind's stream says it holds integers (a strand record's
/// `strand`). [`MeshData::read_normalized`] gives any stream as floats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ComponentType {
    /// Unsigned 8-bit integer.
    U8,
    /// Unsigned 16-bit integer.
    U16,
    /// Unsigned 32-bit integer.
    U32,
    /// 32-bit IEEE float.
    F32,
    /// Signed 8-bit integer, normalized to −1–1 in vertex streams (since format 1.10).
    I8,
    /// Signed 16-bit integer, normalized to −1–1 in vertex streams (since format 1.10).
    I16,
}

impl ComponentType {
    /// Size of one component in bytes.
    pub fn bytes(self) -> usize {
        match self {
            ComponentType::U8 | ComponentType::I8 => 1,
            ComponentType::U16 | ComponentType::I16 => 2,
            ComponentType::U32 | ComponentType::F32 => 4,
        }
    }

    /// Component `k` of element `e` as glTF dequantizes it: floats as they are, 8- and 16-bit
    /// integers normalized (see the type's docs), `U32` as its value.
    pub fn normalized(self, e: &[u8], k: usize) -> f32 {
        match self {
            ComponentType::F32 => f32::from_le_bytes([e[4 * k], e[4 * k + 1], e[4 * k + 2], e[4 * k + 3]]),
            ComponentType::U32 => u32::from_le_bytes([e[4 * k], e[4 * k + 1], e[4 * k + 2], e[4 * k + 3]]) as f32,
            ComponentType::U16 => u16::from_le_bytes([e[2 * k], e[2 * k + 1]]) as f32 / 65535.0,
            ComponentType::U8 => e[k] as f32 / 255.0,
            ComponentType::I16 => (i16::from_le_bytes([e[2 * k], e[2 * k + 1]]) as f32 / 32767.0).max(-1.0),
            ComponentType::I8 => (e[k] as i8 as f32 / 127.0).max(-1.0),
        }
    }

    /// `v` quantized to this 8- or 16-bit type, normalized (clamped to the type's range, rounded
    /// to the nearest step) as little-endian bytes; `None` for `U32` and `F32`.
    fn quantize(self, v: f32) -> Option<Vec<u8>> {
        let v = if v.is_nan() { 0.0 } else { v };
        Some(match self {
            ComponentType::U8 => vec![(v.clamp(0.0, 1.0) * 255.0).round() as u8],
            ComponentType::U16 => ((v.clamp(0.0, 1.0) * 65535.0).round() as u16).to_le_bytes().to_vec(),
            ComponentType::I8 => vec![(v.clamp(-1.0, 1.0) * 127.0).round() as i8 as u8],
            ComponentType::I16 => ((v.clamp(-1.0, 1.0) * 32767.0).round() as i16).to_le_bytes().to_vec(),
            ComponentType::U32 | ComponentType::F32 => return None,
        })
    }
}

/// One stream of a mesh buffer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Accessor {
    /// Attribute name (`position`, `curvature`, …); `index` for the index stream.
    pub name: String,
    /// Byte offset of the first element in the payload.
    pub offset: u64,
    /// Bytes from one element to the next (≥ the element size).
    pub stride: u32,
    /// Scalar type of each component.
    pub component: ComponentType,
    /// Components per element (1 to 4).
    pub components: u8,
    /// Number of elements.
    pub count: u32,
}

/// Longest vertex stride a GPU reads (WebGPU's and wgpu's default `max_vertex_buffer_array_stride`).
pub const MAX_VERTEX_STRIDE: u32 = 2048;

/// The shape in which a GPU fetches a vertex stream: `components` of `component`. A stream of
/// three 8- or 16-bit components is fetched as four, the fourth its padding (written zero):
/// WebGPU, Vulkan, Metal and Bevy have no three-component 8- or 16-bit vertex formats, and
/// glTF pads such elements to 4 bytes the same way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VertexFetch {
    /// Scalar type of each component.
    pub component: ComponentType,
    /// Components fetched (1, 2, 3 or 4; 3 only for 32-bit types).
    pub components: u8,
}

impl Accessor {
    /// How a GPU fetches this stream as a vertex attribute ([`VertexFetch`]), or why it cannot:
    /// the offset and stride must be multiples of 4 (WebGPU's vertex alignment), the stride at
    /// most [`MAX_VERTEX_STRIDE`] and wide enough for the fetched element.
    pub fn vertex_fetch(&self) -> Result<VertexFetch, String> {
        let components = match (self.component.bytes(), self.components) {
            (1 | 2, 3) => 4,
            (_, n) => n,
        };
        let fetched = self.component.bytes() * components as usize;
        if !self.offset.is_multiple_of(4) || !self.stride.is_multiple_of(4) {
            return Err(format!(
                "stream `{}`: offset {} and stride {} must be multiples of 4 to be read as a vertex attribute",
                self.name, self.offset, self.stride
            ));
        }
        if self.stride > MAX_VERTEX_STRIDE || (self.stride as usize) < fetched {
            return Err(format!(
                "stream `{}`: {:?} × {} is fetched as {components} components ({fetched} bytes), expected a stride from \
                 {fetched} to {MAX_VERTEX_STRIDE}, found {}",
                self.name, self.component, self.components, self.stride
            ));
        }
        Ok(VertexFetch { component: self.component, components })
    }

    /// Bytes of one element.
    pub fn element_bytes(&self) -> usize {
        self.component.bytes() * self.components as usize
    }

    /// One past the last byte this accessor reads, or `None` on overflow.
    pub fn end(&self) -> Option<u64> {
        if self.count == 0 {
            return Some(self.offset);
        }
        (self.count as u64 - 1)
            .checked_mul(self.stride as u64)?
            .checked_add(self.offset)?
            .checked_add(self.element_bytes() as u64)
    }
}

/// Layout of a mesh payload, as recorded in the manifest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshDesc {
    /// Vertices per attribute stream.
    pub vertex_count: u32,
    /// Vertex attribute streams; each has `vertex_count` elements.
    pub attributes: Vec<Accessor>,
    /// Triangle-list indices (U16 or U32 scalars), each below `vertex_count`.
    pub indices: Option<Accessor>,
    /// How the payload file stores the buffer: as it is, or as one Zstandard frame (since format
    /// 1.6; absent from the manifest when `none`). The accessors describe the inflated buffer.
    #[serde(default = "Supercompression::none", skip_serializing_if = "Supercompression::is_none")]
    pub supercompression: Supercompression,
}

impl MeshDesc {
    /// The bytes the accessors reach into, rounded up to 4: the buffer a reader uploads (what a
    /// zstd-compressed payload inflates to).
    pub fn buffer_bytes(&self) -> u64 {
        let end = self.attributes.iter().chain(self.indices.iter()).filter_map(Accessor::end).max().unwrap_or(0);
        end.div_ceil(4) * 4
    }

    /// The attribute named `name`.
    pub fn attribute(&self, name: &str) -> Option<&Accessor> {
        self.attributes.iter().find(|a| a.name == name)
    }

    /// Checks every accessor against the payload length: shape, bounds, counts.
    pub fn check(&self, payload_len: u64) -> Result<(), String> {
        let all = self.attributes.iter().chain(self.indices.iter());
        for a in all {
            if !(1..=4).contains(&a.components) {
                return Err(format!("accessor `{}`: expected 1 to 4 components, found {}", a.name, a.components));
            }
            if (a.stride as usize) < a.element_bytes() {
                return Err(format!(
                    "accessor `{}`: stride {} is below the element size {}",
                    a.name,
                    a.stride,
                    a.element_bytes()
                ));
            }
            if a.offset % a.component.bytes() as u64 != 0 || !(a.stride as usize).is_multiple_of(a.component.bytes()) {
                return Err(format!(
                    "accessor `{}`: offset and stride must be multiples of the component size",
                    a.name
                ));
            }
            match a.end() {
                Some(end) if end <= payload_len => {}
                _ => {
                    return Err(format!(
                        "accessor `{}`: {} elements from byte {} with stride {} run past the {payload_len}-byte payload",
                        a.name, a.count, a.offset, a.stride
                    ));
                }
            }
        }
        for a in &self.attributes {
            if a.count != self.vertex_count {
                return Err(format!(
                    "attribute `{}` has {} elements, expected vertex_count {}",
                    a.name, a.count, self.vertex_count
                ));
            }
        }
        if let Some(ix) = &self.indices {
            if !matches!(ix.component, ComponentType::U16 | ComponentType::U32) || ix.components != 1 {
                return Err("indices must be U16 or U32 scalars".into());
            }
            if ix.count % 3 != 0 {
                return Err(format!("{} indices is not a whole number of triangles", ix.count));
            }
        }
        Ok(())
    }
}

/// A mesh payload in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshData {
    /// Layout.
    pub desc: MeshDesc,
    /// The payload bytes.
    pub bytes: Vec<u8>,
}

impl MeshData {
    /// Starts an empty mesh of `vertex_count` vertices; add streams with the `push_*` methods.
    pub fn new(vertex_count: u32) -> Self {
        MeshData {
            desc: MeshDesc {
                vertex_count,
                attributes: Vec::new(),
                indices: None,
                supercompression: Supercompression::None,
            },
            bytes: Vec::new(),
        }
    }

    fn push_stream(
        &mut self,
        name: &str,
        component: ComponentType,
        components: u8,
        count: u32,
        data: &[u8],
    ) -> Accessor {
        self.bytes.resize(self.bytes.len().div_ceil(4) * 4, 0);
        let accessor = Accessor {
            name: name.to_string(),
            offset: self.bytes.len() as u64,
            stride: (component.bytes() * components as usize) as u32,
            component,
            components,
            count,
        };
        self.bytes.extend_from_slice(data);
        accessor
    }

    /// Appends a tightly packed f32 attribute of `components` per vertex.
    pub fn push_f32(&mut self, name: &str, components: u8, values: &[f32]) -> Result<(), BundleError> {
        let expected = self.desc.vertex_count as usize * components as usize;
        if values.len() != expected {
            return Err(BundleError::InvalidData(format!(
                "attribute `{name}`: expected {expected} values, found {}",
                values.len()
            )));
        }
        let data: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let a = self.push_stream(name, ComponentType::F32, components, self.desc.vertex_count, &data);
        self.desc.attributes.push(a);
        Ok(())
    }

    /// Appends an attribute of `components` per vertex quantized to `component` (`U8`, `U16`,
    /// `I8` or `I16`, normalized as glTF's `normalized` accessors and KHR_mesh_quantization
    /// have them), each element padded to a multiple of 4 bytes as glTF wants vertex elements
    /// aligned.
    pub fn push_normalized(
        &mut self,
        name: &str,
        component: ComponentType,
        components: u8,
        values: &[f32],
    ) -> Result<(), BundleError> {
        let expected = self.desc.vertex_count as usize * components as usize;
        if values.len() != expected || !(1..=4).contains(&components) {
            return Err(BundleError::InvalidData(format!(
                "attribute `{name}`: expected {expected} values of 1 to 4 components, found {} of {components}",
                values.len()
            )));
        }
        let element = component.bytes() * components as usize;
        let stride = element.div_ceil(4) * 4;
        let mut data = Vec::with_capacity(stride * self.desc.vertex_count as usize);
        for v in values.chunks_exact(components as usize) {
            for &x in v {
                let bytes = component.quantize(x).ok_or_else(|| {
                    BundleError::InvalidData(format!("attribute `{name}`: {component:?} is not a normalized type"))
                })?;
                data.extend_from_slice(&bytes);
            }
            data.resize(data.len() + stride - element, 0);
        }
        let mut a = self.push_stream(name, component, components, self.desc.vertex_count, &data);
        a.stride = stride as u32;
        self.desc.attributes.push(a);
        Ok(())
    }

    /// Appends a stream of `components` integers per vertex of `component`, as little-endian
    /// `data` (integer streams: joint indices, triangle indices), each element padded to a
    /// multiple of 4 bytes.
    pub fn push_raw(
        &mut self,
        name: &str,
        component: ComponentType,
        components: u8,
        data: &[u8],
    ) -> Result<(), BundleError> {
        let element = component.bytes() * components as usize;
        if data.len() != element * self.desc.vertex_count as usize || !(1..=4).contains(&components) {
            return Err(BundleError::InvalidData(format!(
                "attribute `{name}`: expected {} bytes of 1 to 4 components, found {} of {components}",
                element * self.desc.vertex_count as usize,
                data.len()
            )));
        }
        let stride = element.div_ceil(4) * 4;
        let padded: Vec<u8> = data
            .chunks_exact(element)
            .flat_map(|e| e.iter().copied().chain(std::iter::repeat_n(0, stride - element)))
            .collect();
        let mut a = self.push_stream(name, component, components, self.desc.vertex_count, &padded);
        a.stride = stride as u32;
        self.desc.attributes.push(a);
        Ok(())
    }

    /// Sets the triangle-list index stream (U32).
    pub fn set_indices(&mut self, indices: &[u32]) -> Result<(), BundleError> {
        if let Some(&bad) = indices.iter().find(|&&i| i >= self.desc.vertex_count) {
            return Err(BundleError::InvalidData(format!(
                "index {bad} is not below the vertex count {}",
                self.desc.vertex_count
            )));
        }
        let data: Vec<u8> = indices.iter().flat_map(|v| v.to_le_bytes()).collect();
        let a = self.push_stream("index", ComponentType::U32, 1, indices.len() as u32, &data);
        self.desc.indices = Some(a);
        Ok(())
    }

    /// Reads attribute `name` as f32 values (F32 accessors only), `components` per vertex.
    pub fn read_f32(&self, name: &str) -> Option<Vec<f32>> {
        let a = self.desc.attribute(name)?;
        if a.component != ComponentType::F32 {
            return None;
        }
        Some(
            read_elements(&self.bytes, a)
                .flat_map(|e| e.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect::<Vec<_>>())
                .collect(),
        )
    }

    /// Reads attribute `name` as floats of any component type, `components` per vertex:
    /// 8- and 16-bit streams normalized ([`ComponentType::normalized`]).
    pub fn read_normalized(&self, name: &str) -> Option<Vec<f32>> {
        let a = self.desc.attribute(name)?;
        Some(
            read_elements(&self.bytes, a)
                .flat_map(|e| (0..a.components as usize).map(move |k| a.component.normalized(e, k)))
                .collect(),
        )
    }

    /// The bytes of each element of accessor `a` of this mesh (little-endian components), for
    /// streams of any component type. The accessor must have been checked against the payload
    /// ([`MeshDesc::check`]).
    pub fn elements<'a>(&'a self, a: &'a Accessor) -> impl Iterator<Item = &'a [u8]> + 'a {
        read_elements(&self.bytes, a)
    }

    /// Reads the index stream widened to u32.
    pub fn read_indices(&self) -> Option<Vec<u32>> {
        let a = self.desc.indices.as_ref()?;
        Some(read_elements(&self.bytes, a).map(|e| read_uint(e, a.component)).collect())
    }
}

/// The bytes of each element of `a` (the accessor must have been checked against `bytes`).
pub(crate) fn read_elements<'a>(bytes: &'a [u8], a: &'a Accessor) -> impl Iterator<Item = &'a [u8]> + 'a {
    (0..a.count as usize).map(move |i| {
        let start = a.offset as usize + i * a.stride as usize;
        &bytes[start..start + a.element_bytes()]
    })
}

pub(crate) fn read_uint(e: &[u8], c: ComponentType) -> u32 {
    match c {
        ComponentType::U8 | ComponentType::I8 => e[0] as u32,
        ComponentType::U16 | ComponentType::I16 => u16::from_le_bytes([e[0], e[1]]) as u32,
        ComponentType::U32 | ComponentType::F32 => u32::from_le_bytes([e[0], e[1], e[2], e[3]]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_aligned_and_read_back() {
        let mut m = MeshData::new(3);
        m.push_f32("position", 3, &[0., 0., 0., 1., 0., 0., 0., 1., 0.]).unwrap();
        m.push_f32("width", 1, &[0.5, 0.25, 1.0]).unwrap();
        m.set_indices(&[0, 1, 2]).unwrap();
        m.desc.check(m.bytes.len() as u64).unwrap();
        assert_eq!(m.read_f32("width").unwrap(), vec![0.5, 0.25, 1.0]);
        assert_eq!(m.read_indices().unwrap(), vec![0, 1, 2]);
        // Little-endian bytes of 1.0f32 at the second position's x.
        assert_eq!(&m.bytes[12..16], &[0x00, 0x00, 0x80, 0x3F]);
        assert!(m.set_indices(&[0, 1, 3]).is_err());
        assert!(m.desc.check(10).is_err());
    }

    /// Normalized streams: glTF's dequantization of each type gives the values back within half
    /// a step, out-of-range values clamp, three 8-bit components are padded to a 4-byte stride,
    /// and the bytes are the ones the glTF specification's formulas give.
    #[test]
    fn normalized_streams_quantize_as_gltf_dequantizes() {
        let values = [-1.5f32, -0.3, 0.0, 0.71, 1.0, 2.0];
        let mut m = MeshData::new(2);
        m.push_f32("position", 1, &[0.0, 1.0]).unwrap();
        m.push_normalized("n", ComponentType::I8, 3, &values).unwrap();
        m.push_normalized("t", ComponentType::I16, 3, &values).unwrap();
        m.push_normalized("c", ComponentType::U16, 3, &values).unwrap();
        m.push_normalized("u", ComponentType::U8, 3, &values).unwrap();
        m.desc.check(m.bytes.len() as u64).unwrap();
        let n = m.desc.attribute("n").unwrap();
        assert_eq!((n.stride, n.offset % 4), (4, 0));
        // -1.5 clamps to -127, -0.3 → round(-38.1) = -38, 0.71 → round(90.17) = 90.
        assert_eq!(m.elements(n).next().unwrap(), &[(-127i8) as u8, (-38i8) as u8, 0]);
        assert_eq!(m.elements(n).nth(1).unwrap(), &[90, 127, 127]);
        for (name, step, signed) in [
            ("n", 1.0 / 127.0, true),
            ("t", 1.0 / 32767.0, true),
            ("c", 1.0 / 65535.0, false),
            ("u", 1.0 / 255.0, false),
        ] {
            let back = m.read_normalized(name).unwrap();
            for (v, b) in values.iter().zip(&back) {
                let want = v.clamp(if signed { -1.0 } else { 0.0 }, 1.0);
                assert!((want - b).abs() <= step / 2.0 + 1e-7, "{name}: {v} read back as {b}");
            }
        }
        // glTF: the most negative value also means -1.
        assert_eq!(ComponentType::I8.normalized(&[0x80], 0), -1.0);
        assert_eq!(m.read_normalized("position").unwrap(), vec![0.0, 1.0]);
        assert!(m.push_normalized("bad", ComponentType::F32, 1, &[0.0, 0.0]).is_err());
    }

    /// Every stream the writer makes is one a GPU fetches: 8- and 16-bit triples as four
    /// components over their zero padding, 32-bit triples as they are; streams off a 4-byte
    /// boundary, or too narrow for what is fetched, are not.
    #[test]
    fn written_streams_are_vertex_formats_and_odd_ones_are_named() {
        let values = [0.5f32; 6];
        let mut m = MeshData::new(2);
        m.push_f32("p", 3, &values).unwrap();
        m.push_normalized("n", ComponentType::I8, 3, &values).unwrap();
        m.push_normalized("c", ComponentType::U16, 3, &values).unwrap();
        m.push_normalized("u", ComponentType::U8, 1, &values[..2]).unwrap();
        let fetched: Vec<(ComponentType, u8)> =
            m.desc.attributes.iter().map(|a| a.vertex_fetch().map(|f| (f.component, f.components)).unwrap()).collect();
        assert_eq!(
            fetched,
            [(ComponentType::F32, 3), (ComponentType::I8, 4), (ComponentType::U16, 4), (ComponentType::U8, 1)]
        );
        // The padding a GPU reads as the fourth component is zero.
        let n = m.desc.attribute("n").unwrap().clone();
        assert!(m.bytes[n.offset as usize..].chunks(4).take(2).all(|e| e[3] == 0));
        crate::validate::check_mesh(&m.desc, &m.bytes).unwrap();

        let odd = Accessor { offset: n.offset + 2, ..n.clone() };
        assert!(odd.vertex_fetch().unwrap_err().contains("multiples of 4"), "{:?}", odd.vertex_fetch());
        let narrow = Accessor { stride: 4, component: ComponentType::I16, ..n.clone() };
        let e = narrow.vertex_fetch().unwrap_err();
        assert!(e.contains("fetched as 4 components (8 bytes)") && e.contains("found 4"), "{e}");
        // A triple whose last element's padding would be read past the buffer.
        let mut cut = m.clone();
        cut.desc.attributes.retain(|a| a.name == "n");
        cut.bytes.truncate((n.offset + 4 + 3) as usize);
        let e = crate::validate::check_mesh(&cut.desc, &cut.bytes).unwrap_err();
        assert!(e.contains("past the"), "{e}");
    }
}
