//! Alembic grooms (`.abc`, Ogawa): every curves object of the archive (`AbcGeom_Curve`), placed
//! by the transforms above it, at one time sample. Read by a reader of hikage's own, with every
//! count checked against the file before anything is allocated.
//!
//! - Points (`P`) are placed by every `Xform` object above the curves (up to one that does not
//!   inherit), at the sample nearest the job's `time` (seconds), else the first.
//! - Control points are taken as points, whatever `curveBasisAndType` says (see
//!   [`super::curves`]).
//! - Unreal's groom attributes in `.arbGeomParams`, where present: `groom_width` (diameters),
//!   `groom_color`, `groom_guide` (guides are left out) and `groom_group_id`; `groom_root_uv`
//!   and the rest are not read (strands are bound to a scalp by their roots' places).
//!   `groom_guide` and `groom_group_id` are also read from `.userProperties` of the curves or
//!   of a transform above them, where Blender's exporter writes an object's custom properties.
//! - Widths: `groom_width`, else the schema's `width`, else the job's. Widths and colours in any
//!   scope (constant, uniform, varying, vertex), indexed or not.
//! - Alembic states neither units nor an up axis: the job's `units` and `up` apply, defaulting
//!   to metres and +Y (Blender, Maya and Houdini write Y up).
//!
//! Every mistake names the file and the object: no curves, a truncated or cyclic archive,
//! counts that disagree with the points, a curve of one point, points or widths that are not
//! finite, negative widths.

mod archive;
mod ogawa;

use std::path::Path;

use glam::{DMat4, DVec3};

use super::curves::{self, CurveSet, Interpolation, Problem};
use super::cyhair::HairLimits;
use super::{FileFrame, GroomRead, Strands};
use crate::error::BakeError;
use archive::{Archive, Kind, Object, Property, meta};

/// Reads every curves object of the Alembic archive at `path`.
pub fn load(path: &Path, read: &GroomRead, limits: &HairLimits) -> Result<(Strands, FileFrame), BakeError> {
    let bytes = hikage_bundle::files::read_limited(path, limits.max_file_bytes(), "strand file size")?;
    let fail = |(place, message): Problem| BakeError::input(path, place, message);
    let archive = Archive::open(&bytes).map_err(|m| fail((None, m)))?;
    let mut walk = Walk { archive: &archive, read, limits, sets: Vec::new(), points: 0, stack: Vec::new() };
    let top = Object { name: String::new(), metadata: String::new(), group: archive.top };
    walk.visit(&top, "", DMat4::IDENTITY, Tags::default()).map_err(fail)?;
    let strands = curves::gather(walk.sets, read.group, limits).map_err(fail)?;
    Ok((strands, FileFrame::default()))
}

/// Objects nested deeper than this are refused (a real scene is a few levels deep).
const MAX_DEPTH: usize = 256;

/// Unreal's per-object groom tags, inherited from the transforms above a curves object.
#[derive(Clone, Copy, Debug, Default)]
struct Tags {
    guide: Option<bool>,
    group: Option<i32>,
}

/// The walk down the object tree.
struct Walk<'a, 'b> {
    archive: &'b Archive<'a>,
    read: &'b GroomRead,
    limits: &'b HairLimits,
    sets: Vec<CurveSet>,
    /// Points read so far, against the limit.
    points: u64,
    /// The groups of the objects being visited, to refuse a cycle.
    stack: Vec<u64>,
}

impl Walk<'_, '_> {
    fn visit(&mut self, object: &Object, path: &str, world: DMat4, tags: Tags) -> Result<(), Problem> {
        let place = || Some(format!("object {}", if path.is_empty() { "/" } else { path }));
        let at = |m: String| (place(), m);
        if self.stack.contains(&object.group) {
            return Err(at("the archive is cyclic: this object contains itself".into()));
        }
        if self.stack.len() >= MAX_DEPTH {
            return Err(at(format!("objects nested deeper than {MAX_DEPTH} levels")));
        }
        let (props, below) = self.archive.object(object.group).map_err(at)?;
        let props = self.archive.properties(props).map_err(at)?;
        let schema = meta(&object.metadata, "schema").unwrap_or("");
        let (mut world, mut tags) = (world, tags);
        if schema.starts_with("AbcGeom_Xform") {
            let xform = self.archive.compound(find(&props, ".xform").map_err(at)?).map_err(at)?;
            let (local, inherits) = self.transform(&xform).map_err(at)?;
            world = if inherits { world * local } else { local };
            tags = self.tags(&xform, tags).map_err(at)?;
        } else if schema.starts_with("AbcGeom_Curve") {
            let geom = self.archive.compound(find(&props, ".geom").map_err(at)?).map_err(at)?;
            let set = self.curves(&geom, world, tags).map_err(at)?;
            self.points += set.points.len() as u64;
            self.sets.push(set);
        }
        self.stack.push(object.group);
        for child in &below {
            self.visit(child, &format!("{path}/{}", child.name), world, tags)?;
        }
        self.stack.pop();
        Ok(())
    }

    /// An `Xform`'s matrix from its operations (first op outermost) and whether it inherits
    /// its parent's.
    fn transform(&self, xform: &[Property]) -> Result<(DMat4, bool), String> {
        let time = self.read.time;
        let inherits = match xform.iter().find(|p| p.name == ".inherits") {
            Some(p) => archive::integers(p, self.archive.sample(p, time)?)?.first().is_none_or(|&v| v != 0),
            None => true,
        };
        let Some(ops) = xform.iter().find(|p| p.name == ".ops") else { return Ok((DMat4::IDENTITY, inherits)) };
        let ops = archive::integers(ops, self.archive.sample(ops, time)?)?;
        let vals = match xform.iter().find(|p| p.name == ".vals") {
            Some(p) => doubles(p, self.archive.sample(p, time)?)?,
            None => Vec::new(),
        };
        let mut m = DMat4::IDENTITY;
        let mut v = vals.as_slice();
        for (i, &op) in ops.iter().enumerate() {
            let n = match op >> 4 {
                0 | 1 => 3,
                2 => 4,
                3 => 16,
                4..=6 => 1,
                other => return Err(format!(".xform operation {i} is of type {other}: expected 0 to 6")),
            };
            let Some((c, rest)) = v.split_at_checked(n) else {
                return Err(format!(".xform holds {} values for its {} operations", vals.len(), ops.len()));
            };
            v = rest;
            let axis = |x: f64, y: f64, z: f64, deg: f64| DMat4::from_axis_angle(DVec3::new(x, y, z), deg.to_radians());
            m *= match op >> 4 {
                0 => DMat4::from_scale(DVec3::new(c[0], c[1], c[2])),
                1 => DMat4::from_translation(DVec3::new(c[0], c[1], c[2])),
                2 => {
                    let a = DVec3::new(c[0], c[1], c[2])
                        .try_normalize()
                        .ok_or_else(|| format!(".xform operation {i} rotates about a zero axis"))?;
                    axis(a.x, a.y, a.z, c[3])
                }
                // Imath's row-major matrix, for row vectors: glam's columns are its rows.
                3 => DMat4::from_cols_slice(c),
                4 => axis(1.0, 0.0, 0.0, c[0]),
                5 => axis(0.0, 1.0, 0.0, c[0]),
                _ => axis(0.0, 0.0, 1.0, c[0]),
            };
        }
        if !m.is_finite() {
            return Err(".xform's matrix is not finite".into());
        }
        Ok((m, inherits))
    }

    /// `tags` with those a compound's `.userProperties` sets (Blender's custom properties).
    fn tags(&self, compound: &[Property], mut tags: Tags) -> Result<Tags, String> {
        let Some(user) = compound.iter().find(|p| p.name == ".userProperties") else { return Ok(tags) };
        for p in self.archive.compound(user)? {
            if p.name == "groom_guide" || p.name == "groom_group_id" {
                let v = self.numbers(&p)?;
                let [v] = v[..] else { return Err(format!("{} holds {} values: expected 1", p.name, v.len())) };
                match p.name.as_str() {
                    "groom_guide" => tags.guide = Some(v != 0),
                    _ => tags.group = Some(group_id(v, &p.name)?),
                }
            }
        }
        Ok(tags)
    }

    /// A property's numbers at the job's time, integers or floats rounded.
    fn numbers(&self, p: &Property) -> Result<Vec<i64>, String> {
        let bytes = self.archive.sample(p, self.read.time)?;
        match p.pod {
            9..=11 => Ok(archive::floats(p, bytes)?.iter().map(|v| v.round() as i64).collect()),
            _ => archive::integers(p, bytes),
        }
    }

    /// A curves object's `.geom`: its curves in the world frame.
    fn curves(&self, geom: &[Property], world: DMat4, tags: Tags) -> Result<CurveSet, String> {
        let time = self.read.time;
        let p = find(geom, "P")?;
        if p.extent != 3 {
            return Err(format!("P has {} components a point: expected 3", p.extent));
        }
        let p_bytes = self.archive.sample(p, time)?;
        let n_vertices = find(geom, "nVertices")?;
        let counts = archive::integers(n_vertices, self.archive.sample(n_vertices, time)?)?;
        // Counted before the points are converted, against the limit.
        let size = match p.pod {
            11 => 24,
            9 => 6,
            _ => 12,
        };
        let counts = curves::check_counts(&counts, (p_bytes.len() / size) as u64, self.points, self.limits)?;
        let mut points = Vec::with_capacity(counts.iter().sum());
        let mut place = |i: usize, c: [f32; 3]| {
            let q = world.transform_point3(DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64)).as_vec3();
            if !q.is_finite() {
                return Err(format!("point {i} is ({}, {}, {}): expected finite coordinates", c[0], c[1], c[2]));
            }
            points.push(q.to_array());
            Ok(())
        };
        if p.pod == 10 {
            // Float points, the common case, straight from the file's bytes.
            for (i, b) in p_bytes.chunks_exact(12).enumerate() {
                let f = |k: usize| f32::from_le_bytes(b[4 * k..4 * k + 4].try_into().expect("4 bytes"));
                place(i, [f(0), f(1), f(2)])?;
            }
        } else {
            for (i, c) in archive::floats(p, p_bytes)?.chunks_exact(3).enumerate() {
                place(i, [c[0], c[1], c[2]])?;
            }
        }
        let scale = {
            let axis = |v: DVec3| world.transform_vector3(v).length();
            (axis(DVec3::X) * axis(DVec3::Y) * axis(DVec3::Z)).cbrt() as f32
        };
        let arb = match geom.iter().find(|p| p.name == ".arbGeomParams") {
            Some(p) => self.archive.compound(p)?,
            None => Vec::new(),
        };
        let widths = match self.param(&arb, "groom_width", &counts)? {
            Some(w) => Some(("groom_width", w)),
            None => self.param(geom, "width", &counts)?.map(|w| ("width", w)),
        };
        let widths = match widths {
            None => None,
            Some((name, (1, w))) => {
                curves::check_widths(&w, name)?;
                Some(w.iter().map(|v| v * scale).collect())
            }
            Some((name, (extent, _))) => return Err(format!("{name} has {extent} components a value: expected 1")),
        };
        let colors = match self.param(&arb, "groom_color", &counts)? {
            None => None,
            Some((extent @ (3 | 4), c)) => {
                let c: Vec<[f32; 3]> = c.chunks_exact(extent).map(|v| [v[0], v[1], v[2]]).collect();
                curves::check_colors(&c, "groom_color")?;
                Some(c)
            }
            Some((extent, _)) => return Err(format!("groom_color has {extent} components a value: expected 3 or 4")),
        };
        let own = self.tags(geom, tags)?;
        let flags = |name: &str| -> Result<Option<Vec<i64>>, String> {
            match arb.iter().find(|p| p.name == name) {
                Some(p) if p.kind != Kind::Compound => curves::per_curve(&self.numbers(p)?, &counts, name).map(Some),
                _ => Ok(None),
            }
        };
        let guides = match flags("groom_guide")? {
            Some(g) => Some(g.iter().map(|&v| v != 0).collect()),
            None => own.guide.map(|g| vec![g; counts.len()]),
        };
        let groups = match flags("groom_group_id")? {
            Some(g) => Some(g.iter().map(|&v| group_id(v, "groom_group_id")).collect::<Result<_, _>>()?),
            None => own.group.map(|g| vec![g; counts.len()]),
        };
        Ok(CurveSet { counts, points, widths, colors, guides, groups })
    }

    /// A geometry parameter (plain, or indexed: `.vals` and `.indices`), spread over the
    /// points: its components a value and the values.
    fn param(&self, props: &[Property], name: &str, counts: &[usize]) -> Result<Option<(usize, Vec<f32>)>, String> {
        let Some(p) = props.iter().find(|p| p.name == name) else { return Ok(None) };
        let time = self.read.time;
        let (values, extent) = if p.kind == Kind::Compound {
            let parts = self.archive.compound(p)?;
            let vals = find(&parts, ".vals")?;
            let extent = vals.extent.max(1) as usize;
            let all = archive::floats(vals, self.archive.sample(vals, time)?)?;
            let indices = find(&parts, ".indices")?;
            let indices = archive::integers(indices, self.archive.sample(indices, time)?)?;
            // At most one value a point (or a curve) before any is expanded.
            let most = counts.iter().sum::<usize>().max(counts.len());
            if indices.len() > most {
                return Err(format!("{name} holds {} indices: expected at most one a point ({most})", indices.len()));
            }
            let mut out = Vec::with_capacity(indices.len() * extent);
            for &i in &indices {
                let start = usize::try_from(i).ok().and_then(|i| i.checked_mul(extent));
                let value = start.and_then(|s| all.get(s..s.checked_add(extent)?));
                out.extend_from_slice(
                    value.ok_or_else(|| format!("{name}: index {i} past its {} values", all.len() / extent))?,
                );
            }
            (out, extent)
        } else {
            (archive::floats(p, self.archive.sample(p, time)?)?, p.extent.max(1) as usize)
        };
        let len = values.len() / extent;
        let interpolation = match meta(&p.metadata, "geoScope") {
            Some("con") => Interpolation::Constant,
            Some("uni") => Interpolation::Uniform,
            Some("var") => Interpolation::Varying,
            Some("vtx") => Interpolation::Vertex,
            Some(other) => return Err(format!("{name} has scope {other:?}: expected con, uni, var or vtx")),
            None => Interpolation::by_count(len, counts).ok_or_else(|| {
                format!(
                    "{name} holds {len} values: expected 1, one a curve ({}) or one a point ({})",
                    counts.len(),
                    counts.iter().sum::<usize>()
                )
            })?,
        };
        let points: usize = counts.iter().sum();
        if matches!(interpolation, Interpolation::Vertex | Interpolation::Varying) && len == points {
            return Ok(Some((extent, values)));
        }
        // Spread by value index, then each point takes its value's components.
        let index: Vec<usize> = (0..len).collect();
        let per_point = curves::spread(&index, interpolation, counts, name)?;
        Ok(Some((
            extent,
            per_point.iter().flat_map(|&i| values[i * extent..(i + 1) * extent].iter().copied()).collect(),
        )))
    }
}

/// The property named `name`, which must be there.
fn find<'p>(props: &'p [Property], name: &str) -> Result<&'p Property, String> {
    props.iter().find(|p| p.name == name).ok_or_else(|| format!("no {name} property"))
}

/// Values of a float property at full precision (transforms).
fn doubles(p: &Property, bytes: &[u8]) -> Result<Vec<f64>, String> {
    match p.pod {
        11 => Ok(bytes.chunks_exact(8).map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes"))).collect()),
        _ => Ok(archive::floats(p, bytes)?.iter().map(|&v| v as f64).collect()),
    }
}

/// A group id, which must fit Unreal's `int`.
fn group_id(v: i64, name: &str) -> Result<i32, String> {
    i32::try_from(v).map_err(|_| format!("{name} {v}: expected a 32-bit integer"))
}
