//! A small Alembic (Ogawa) writer for tests and benchmarks: objects holding properties, each
//! property one sample at time 0, laid out as Alembic's own Ogawa writer lays them out (a group
//! a property or object, a header block last, a 16-byte digest before each sample).
//!
//! It writes what no tool on this machine writes (Blender's exporter drops curve attributes;
//! no Alembic library is packaged here): the `.arbGeomParams` Unreal reads, indexed values, a
//! groom large enough to measure. The committed grooms come from Blender.

/// A property of one sample.
pub enum Prop {
    /// An array of values.
    Array(Values),
    /// One value.
    Scalar(Values),
    /// Properties under a name: the name, metadata, and the properties.
    Compound(String, String, Vec<Prop>),
}

/// A scalar or array property's sample.
pub struct Values {
    /// The property's name.
    pub name: String,
    /// Alembic's plain-old-data number: 1 uint8, 6 int32, 10 float32, 11 float64, ….
    pub pod: u8,
    /// Components a value.
    pub extent: u8,
    /// Metadata (`geoScope=uni;isGeomParam=true`, …).
    pub meta: String,
    /// The values' bytes, little-endian.
    pub bytes: Vec<u8>,
}

/// An object.
pub struct Object {
    /// Its name.
    pub name: String,
    /// Its metadata (`schema=AbcGeom_Curve_v2`, …).
    pub meta: String,
    /// Its properties.
    pub props: Vec<Prop>,
    /// The objects below it.
    pub children: Vec<Object>,
}

/// Values of `pod` with `extent` components.
fn values(name: &str, pod: u8, extent: u8, meta: &str, bytes: Vec<u8>) -> Values {
    Values { name: name.into(), pod, extent, meta: meta.into(), bytes }
}

impl Prop {
    /// An array of `f32` values of `extent` components.
    pub fn floats(name: &str, extent: u8, meta: &str, values: &[f32]) -> Prop {
        Prop::Array(self::values(name, 10, extent, meta, values.iter().flat_map(|v| v.to_le_bytes()).collect()))
    }

    /// An array of `i32` values.
    pub fn ints(name: &str, meta: &str, values: &[i32]) -> Prop {
        Prop::Array(self::values(name, 6, 1, meta, values.iter().flat_map(|v| v.to_le_bytes()).collect()))
    }

    /// A compound of `props`.
    pub fn compound(name: &str, meta: &str, props: Vec<Prop>) -> Prop {
        Prop::Compound(name.into(), meta.into(), props)
    }

    /// An `Xform`'s `.xform` compound of one translation.
    pub fn translate(t: [f64; 3]) -> Prop {
        let vals = t.iter().flat_map(|v| v.to_le_bytes()).collect();
        Prop::compound(
            ".xform",
            "schema=AbcGeom_Xform_v3",
            vec![Prop::Scalar(values(".ops", 1, 1, "", vec![0x10])), Prop::Scalar(values(".vals", 11, 3, "", vals))],
        )
    }
}

/// The high bit of a child offset: a data block.
const DATA: u64 = 1 << 63;

struct Writer {
    out: Vec<u8>,
}

impl Writer {
    fn data(&mut self, bytes: &[u8]) -> u64 {
        let at = self.out.len() as u64;
        self.out.extend((bytes.len() as u64).to_le_bytes());
        self.out.extend(bytes);
        at | DATA
    }

    fn group(&mut self, children: &[u64]) -> u64 {
        let at = self.out.len() as u64;
        self.out.extend((children.len() as u64).to_le_bytes());
        children.iter().for_each(|c| self.out.extend(c.to_le_bytes()));
        at
    }

    /// The compound of `props`: one group a property, then their headers.
    fn props(&mut self, props: &[Prop]) -> u64 {
        let mut children = Vec::new();
        let mut headers = Vec::new();
        for p in props {
            // Info: kind (0 compound, 1 scalar, 2 array), sizes of 4 bytes (hint 2), and for
            // samples the data type, "all samples the same" (0x800) and the extent;
            // metadata inline (index 0xff).
            let (info, name, meta) = match p {
                Prop::Compound(name, meta, props) => {
                    children.push(self.props(props));
                    (8, name, meta)
                }
                Prop::Array(v) | Prop::Scalar(v) => {
                    let sample = self.data(&[&[0u8; 16], v.bytes.as_slice()].concat());
                    let array = matches!(p, Prop::Array(_));
                    children.push(if array {
                        let dims = self.data(&[]);
                        self.group(&[sample, dims])
                    } else {
                        self.group(&[sample])
                    });
                    let kind = if array { 2 } else { 1 };
                    (kind | 8 | (v.pod as u32) << 4 | 0x800 | (v.extent as u32) << 12, &v.name, &v.meta)
                }
            };
            headers.extend((info | 0xff << 20).to_le_bytes());
            if !matches!(p, Prop::Compound(..)) {
                // One sample.
                headers.extend(1u32.to_le_bytes());
            }
            for text in [name, meta] {
                headers.extend((text.len() as u32).to_le_bytes());
                headers.extend(text.as_bytes());
            }
        }
        children.push(self.data(&headers));
        self.group(&children)
    }

    /// An object: its properties, the objects below, their headers and two 16-byte hashes.
    fn object(&mut self, props: &[Prop], children: &[Object]) -> u64 {
        let mut groups = vec![self.props(props)];
        let mut headers = Vec::new();
        for child in children {
            groups.push(self.object(&child.props, &child.children));
            headers.extend((child.name.len() as u32).to_le_bytes());
            headers.extend(child.name.as_bytes());
            headers.push(0xff);
            headers.extend((child.meta.len() as u32).to_le_bytes());
            headers.extend(child.meta.as_bytes());
        }
        headers.extend([0; 32]);
        groups.push(self.data(&headers));
        self.group(&groups)
    }
}

/// An Ogawa archive whose top object holds `objects`, with one time sampling (uniform, one
/// sample a second from 0).
pub fn archive(objects: &[Object]) -> Vec<u8> {
    let mut w = Writer { out: b"Ogawa\xff\x00\x01".to_vec() };
    w.out.extend([0; 8]);
    let top = w.object(&[], objects);
    let times = [1u32.to_le_bytes().as_slice(), &1f64.to_le_bytes(), &1u32.to_le_bytes(), &0f64.to_le_bytes()].concat();
    let root = [
        w.data(&0i32.to_le_bytes()),
        w.data(&10803i32.to_le_bytes()),
        top,
        w.data(b"_ai_Application=hikage-devkit"),
        w.data(&times),
        w.data(&[]),
    ];
    let root = w.group(&root);
    w.out[8..16].copy_from_slice(&root.to_le_bytes());
    w.out
}

/// A curves object (`AbcGeom_Curve_v2`) named `name` with `P`, `nVertices` and `more` in its
/// `.geom`.
pub fn curves(name: &str, points: &[[f32; 3]], counts: &[i32], more: Vec<Prop>) -> Object {
    let flat: Vec<f32> = points.iter().flatten().copied().collect();
    let mut geom = vec![
        Prop::floats("P", 3, "geoScope=vtx;interpretation=point", &flat),
        Prop::ints("nVertices", "", counts),
        // Linear, non-periodic, no basis: control points are points anyway.
        Prop::Scalar(values("curveBasisAndType", 1, 4, "", vec![1, 0, 0, 1])),
    ];
    geom.extend(more);
    Object {
        name: name.into(),
        meta: "schema=AbcGeom_Curve_v2".into(),
        props: vec![Prop::compound(".geom", "schema=AbcGeom_Curve_v2", geom)],
        children: Vec::new(),
    }
}
