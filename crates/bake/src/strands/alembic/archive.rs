//! The Alembic layer over Ogawa: the archive's metadata table and time samplings, objects and
//! their headers, properties and their samples. Every count and length is checked against the
//! bytes that hold it before anything is allocated for it.

use super::ogawa::{Node, Ogawa};

/// An open archive.
pub(super) struct Archive<'a> {
    file: Ogawa<'a>,
    /// The archive's shared metadata strings (entry 0 is the empty one).
    metadata: Vec<String>,
    times: Vec<TimeSampling>,
    /// The top object's group.
    pub top: u64,
}

/// When a property's samples fall: `per_cycle` seconds a cycle of `times` (one time: uniform;
/// several: cyclic), or `times` alone when acyclic.
struct TimeSampling {
    per_cycle: f64,
    times: Vec<f64>,
}

/// An object below another: its name, metadata, and the group holding it.
pub(super) struct Object {
    pub name: String,
    pub metadata: String,
    pub group: u64,
}

/// What a property holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    /// Other properties.
    Compound,
    /// One value (of `extent` components) a sample.
    Scalar,
    /// An array of values a sample.
    Array,
}

/// A property's header and the group holding its samples (or, for a compound, its properties).
pub(super) struct Property {
    pub name: String,
    pub kind: Kind,
    /// Alembic's plain-old-data type (0 bool … 11 float64, 12–13 strings).
    pub pod: u8,
    /// Components a value.
    pub extent: u8,
    pub metadata: String,
    samples: u32,
    first_changed: u32,
    last_changed: u32,
    time_sampling: u32,
    group: u64,
}

/// Bytes of one component of each plain-old-data type, by its number.
const POD_BYTES: [usize; 12] = [1, 1, 1, 2, 2, 4, 4, 8, 8, 2, 4, 8];

/// The time-per-cycle that marks an acyclic sampling (the largest double over 32).
const ACYCLIC: f64 = f64::MAX / 32.0;

/// A metadata value (`key=value;key=value`).
pub(super) fn meta<'m>(metadata: &'m str, key: &str) -> Option<&'m str> {
    metadata.split(';').filter_map(|kv| kv.split_once('=')).find(|(k, _)| *k == key).map(|(_, v)| v)
}

/// Reads through a header block, every read checked against its end.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
    what: &'static str,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len()).ok_or_else(|| {
            format!(
                "the {} end at byte {} of {}, short of the {n} more they claim",
                self.what,
                self.at,
                self.bytes.len()
            )
        })?;
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }

    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().expect("4 bytes")))
    }

    /// An unsigned number of 1, 2 or 4 bytes, by a header's size hint.
    fn sized(&mut self, hint: u32) -> Result<u32, String> {
        Ok(match hint {
            0 => self.take(1)?[0] as u32,
            1 => u16::from_le_bytes(self.take(2)?.try_into().expect("2 bytes")) as u32,
            _ => self.u32()?,
        })
    }

    fn text(&mut self, n: usize) -> Result<String, String> {
        Ok(String::from_utf8_lossy(self.take(n)?).into_owned())
    }

    fn done(&self) -> bool {
        self.at >= self.bytes.len()
    }
}

impl<'a> Archive<'a> {
    /// The archive in `bytes`: its version, time samplings and metadata table.
    pub(super) fn open(bytes: &'a [u8]) -> Result<Archive<'a>, String> {
        let (file, root) = Ogawa::open(bytes)?;
        let children = file.children(root)?;
        let data = |i: usize| match children.get(i) {
            Some(Node::Data(at)) => file.data(*at),
            _ => Err(format!("the archive's root lacks its entry {i}: expected the Alembic layout")),
        };
        let version = data(0)?;
        if version.len() != 4 || version != [0; 4] {
            return Err(format!("Alembic file version {version:?}: expected 0"));
        }
        let top = match children.get(2) {
            Some(Node::Group(at)) => *at,
            _ => return Err("the archive has no top object".into()),
        };
        let times = time_samplings(data(4)?)?;
        let mut metadata = vec![String::new()];
        if children.len() > 5 {
            let mut c = Cursor { bytes: data(5)?, at: 0, what: "archive's metadata table" };
            while !c.done() {
                let n = c.take(1)?[0] as usize;
                metadata.push(c.text(n)?);
            }
        }
        Ok(Archive { file, metadata, times, top })
    }

    fn indexed(&self, index: u32, cursor: &mut Cursor, hint: Option<u32>) -> Result<String, String> {
        if index == 0xff {
            let n = match hint {
                Some(h) => cursor.sized(h)?,
                None => cursor.u32()?,
            };
            return cursor.text(n as usize);
        }
        self.metadata
            .get(index as usize)
            .cloned()
            .ok_or_else(|| format!("metadata entry {index}: the archive's table holds {}", self.metadata.len()))
    }

    /// The object in `group`: the group of its own properties and the objects below it.
    pub(super) fn object(&self, group: u64) -> Result<(u64, Vec<Object>), String> {
        let children = self.file.children(group)?;
        let properties = match children.first() {
            None => return Ok((0, Vec::new())),
            Some(Node::Group(at)) => *at,
            Some(Node::Data(_)) => return Err(format!("the object at byte {group} has no property group")),
        };
        let mut below = Vec::new();
        if let Some(&Node::Data(at)) = children.last().filter(|_| children.len() > 1) {
            // The headers, then two 16-byte hashes.
            let bytes = self.file.data(at)?;
            let bytes = &bytes[..bytes.len().saturating_sub(32)];
            let mut c = Cursor { bytes, at: 0, what: "object headers" };
            while !c.done() {
                let n = c.u32()? as usize;
                let name = c.text(n)?;
                let index = c.take(1)?[0] as u32;
                let metadata = self.indexed(index, &mut c, None)?;
                let group = match children.get(below.len() + 1) {
                    Some(Node::Group(at)) => *at,
                    _ => return Err(format!("object {name:?} is named in its parent's headers but not stored")),
                };
                below.push(Object { name, metadata, group });
            }
        }
        Ok((properties, below))
    }

    /// The properties in the compound property stored in `group`.
    pub(super) fn properties(&self, group: u64) -> Result<Vec<Property>, String> {
        let children = self.file.children(group)?;
        let Some(&Node::Data(at)) = children.last() else { return Ok(Vec::new()) };
        let mut c = Cursor { bytes: self.file.data(at)?, at: 0, what: "property headers" };
        let mut out = Vec::new();
        while !c.done() {
            let info = c.u32()?;
            let hint = (info >> 2) & 3;
            let kind = match info & 3 {
                0 => Kind::Compound,
                1 => Kind::Scalar,
                _ => Kind::Array,
            };
            let (mut pod, mut extent, mut samples, mut first, mut last, mut ts) = (0, 0, 0, 0, 0, 0);
            if kind != Kind::Compound {
                pod = ((info >> 4) & 0xf) as u8;
                extent = ((info >> 12) & 0xff) as u8;
                if pod > 13 {
                    return Err(format!("a property of data type {pod}: expected 0 to 13"));
                }
                samples = c.sized(hint)?;
                (first, last) = if info & 0x200 != 0 {
                    (c.sized(hint)?, c.sized(hint)?)
                } else if info & 0x800 != 0 {
                    (0, 0)
                } else {
                    (1, samples.saturating_sub(1))
                };
                if info & 0x100 != 0 {
                    ts = c.sized(hint)?;
                }
            }
            let n = c.sized(hint)? as usize;
            let name = c.text(n)?;
            let metadata = self.indexed((info >> 20) & 0xff, &mut c, Some(hint))?;
            let group = match children.get(out.len()) {
                Some(Node::Group(at)) if out.len() + 1 < children.len() => *at,
                _ => return Err(format!("property {name:?} is named in its compound's headers but not stored")),
            };
            out.push(Property {
                name,
                kind,
                pod,
                extent,
                metadata,
                samples,
                first_changed: first,
                last_changed: last,
                time_sampling: ts,
                group,
            });
        }
        Ok(out)
    }

    /// The properties of the compound `p`.
    pub(super) fn compound(&self, p: &Property) -> Result<Vec<Property>, String> {
        match p.kind {
            Kind::Compound => self.properties(p.group),
            _ => Err(format!("{} is not a compound property", p.name)),
        }
    }

    /// The sample of `p` nearest `time` seconds (the first without one): its values' bytes,
    /// a whole number of values of `extent` components.
    pub(super) fn sample(&self, p: &Property, time: Option<f64>) -> Result<&'a [u8], String> {
        let size =
            POD_BYTES.get(p.pod as usize).ok_or_else(|| format!("{} holds strings: expected numbers", p.name))?
                * p.extent.max(1) as usize;
        if p.samples == 0 {
            return Err(format!("{} has no samples", p.name));
        }
        let index = match time {
            None => 0,
            Some(t) => self.nearest(p, t)?,
        };
        // Samples equal to their neighbours are stored once.
        let stored = if index < p.first_changed || (p.first_changed == 0 && p.last_changed == 0) {
            0
        } else if p.last_changed < p.first_changed {
            return Err(format!("{}: its last changed sample comes before its first", p.name));
        } else {
            index.min(p.last_changed) - p.first_changed + 1
        } as usize;
        let children = self.file.children(p.group)?;
        let slot = if p.kind == Kind::Array { 2 * stored } else { stored };
        let bytes = match children.get(slot) {
            Some(Node::Data(at)) => self.file.data(*at)?,
            _ => return Err(format!("{} lacks its sample {index}", p.name)),
        };
        if bytes.is_empty() {
            return Ok(bytes);
        }
        // Each sample starts with a 16-byte digest of its values.
        let values = bytes
            .get(16..)
            .ok_or_else(|| format!("{}: a sample of {} bytes, shorter than its digest", p.name, bytes.len()))?;
        if values.len() % size != 0 {
            return Err(format!(
                "{}: a sample of {} bytes is not a whole number of {size}-byte values",
                p.name,
                values.len()
            ));
        }
        Ok(values)
    }

    /// The index of `p`'s sample nearest `t` seconds.
    fn nearest(&self, p: &Property, t: f64) -> Result<u32, String> {
        let ts = self.times.get(p.time_sampling as usize).ok_or_else(|| {
            format!("{} names time sampling {}: the archive holds {}", p.name, p.time_sampling, self.times.len())
        })?;
        let at = |i: u32| ts.time(i);
        // The last sample at or before t, then whichever of it and the next is nearer.
        let (mut lo, mut hi) = (0u32, p.samples - 1);
        while lo < hi {
            let mid = lo + (hi - lo).div_ceil(2);
            if at(mid) <= t { lo = mid } else { hi = mid - 1 }
        }
        Ok(if lo + 1 < p.samples && (at(lo + 1) - t).abs() < (t - at(lo)).abs() { lo + 1 } else { lo })
    }
}

impl TimeSampling {
    /// The time of sample `i`, seconds.
    fn time(&self, i: u32) -> f64 {
        let Some(&last) = self.times.last() else { return 0.0 };
        if self.per_cycle >= ACYCLIC {
            return self.times.get(i as usize).copied().unwrap_or(last);
        }
        let n = self.times.len() as u32;
        self.times[(i % n) as usize] + (i / n) as f64 * self.per_cycle
    }
}

/// The archive's time samplings: for each, its largest sample count, seconds per cycle, and the
/// times of one cycle.
fn time_samplings(bytes: &[u8]) -> Result<Vec<TimeSampling>, String> {
    let mut c = Cursor { bytes, at: 0, what: "time samplings" };
    let mut out = Vec::new();
    while !c.done() {
        let _max_samples = c.u32()?;
        let per_cycle = f64::from_le_bytes(c.take(8)?.try_into().expect("8 bytes"));
        let n = c.u32()? as usize;
        let times = c.take(n.checked_mul(8).ok_or("time samplings: a count past the address space")?)?;
        let times: Vec<f64> =
            times.chunks_exact(8).map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes"))).collect();
        if !per_cycle.is_finite() || times.iter().any(|t| !t.is_finite()) {
            return Err("a time sampling with a time that is not finite".into());
        }
        out.push(TimeSampling { per_cycle, times });
    }
    Ok(out)
}

/// Values of a numeric property as floats (`float16`, `float32`, `float64`).
pub(super) fn floats(p: &Property, bytes: &[u8]) -> Result<Vec<f32>, String> {
    Ok(match p.pod {
        9 => bytes.chunks_exact(2).map(|b| half::f16::from_le_bytes([b[0], b[1]]).to_f32()).collect(),
        10 => bytes.chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes"))).collect(),
        11 => bytes.chunks_exact(8).map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")) as f32).collect(),
        other => return Err(format!("{} holds data type {other}: expected floating-point numbers", p.name)),
    })
}

/// Values of an integer or boolean property, as `i64`.
pub(super) fn integers(p: &Property, bytes: &[u8]) -> Result<Vec<i64>, String> {
    let size = *POD_BYTES
        .get(p.pod as usize)
        .filter(|_| p.pod <= 8)
        .ok_or_else(|| format!("{} holds data type {}: expected integers", p.name, p.pod))?;
    let signed = matches!(p.pod, 2 | 4 | 6 | 8);
    Ok(bytes
        .chunks_exact(size)
        .map(|b| {
            let mut wide = [if signed && b[size - 1] & 0x80 != 0 { 0xff } else { 0 }; 8];
            wide[..size].copy_from_slice(b);
            i64::from_le_bytes(wide)
        })
        .collect())
}
