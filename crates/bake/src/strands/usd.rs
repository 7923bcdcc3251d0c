//! USD grooms (`.usd`, `.usda`, `.usdc`, `.usdz`): every `BasisCurves` prim of the stage, in
//! the stage's world frame, read with the `openusd` crate.
//!
//! - Points are placed by each prim's transform stack (its own `xformOp`s and its ancestors',
//!   up to a `!resetXformStack!`), at the default time or, when only time samples are authored,
//!   the first sample.
//! - Control points are taken as points, whatever the `basis`, `type` and `wrap`: a pinned
//!   Catmull-Rom curve (Blender, Houdini) passes through them, and hair strips are polylines of
//!   their own. Unreal's groom importer does the same.
//! - `widths` (diameters) in every interpolation: `constant`, `uniform` (one per curve),
//!   `varying` and `vertex`; `primvars:displayColor` likewise. The widest point is the
//!   default thickness that the job's widths stand for. A prim without widths leaves them to
//!   the job (`shading_width`).
//! - The stage's `metersPerUnit` and `upAxis` are returned with the strands
//!   ([`super::FileFrame`]); the job turns them into the bundle's frame.
//!
//! Every mistake names the file and the prim: no curves at all, counts that disagree with the
//! points, a curve of one point, points or widths that are not finite, negative widths. Layers
//! the stage names (sublayers, references) are opened only when they are regular files within
//! the size bound, and one that cannot be read is an error, not strands left out.

use std::cell::Cell;
use std::panic::AssertUnwindSafe;
use std::path::Path;
use std::sync::Once;

use openusd::ar;
use openusd::gf::{Matrix4d, Vec3f};
use openusd::schemas::geom::{self, Curves, Imageable, PointBased, Xformable};
use openusd::sdf;
use openusd::usd::{self, Prim, SchemaBase, SchemaKind};

use super::curves::{self, CurveSet, Interpolation, Problem};
use super::cyhair::HairLimits;
use super::{FileFrame, GroomRead, Strands, UpAxis};
use crate::error::BakeError;

/// Any prim, seen as transformable: its `xformOp`s are read whatever its type.
struct Placed(Prim);

impl SchemaBase for Placed {
    const KIND: SchemaKind = SchemaKind::AbstractTyped;
    fn prim(&self) -> &Prim {
        &self.0
    }
}
impl Imageable for Placed {}
impl Xformable for Placed {}

/// Reads every `BasisCurves` prim of the stage at `path`.
pub fn load(path: &Path, read: &GroomRead, limits: &HairLimits) -> Result<(Strands, FileFrame), BakeError> {
    let fail = |place: Option<String>, message: String| BakeError::input(path, place, message);
    let text = path.to_str().ok_or_else(|| fail(None, "expected a path that is valid UTF-8".into()))?;
    // The parser is a third party's: a panic inside it is a malformed file, not a crash.
    let unreadable = || fail(None, "the USD parser could not read this file (it is damaged or not USD)".into());
    let resolver = Guarded { inner: ar::DefaultResolver::new(), max_bytes: limits.max_file_bytes() };
    let stage = match quietly(|| usd::Stage::builder().resolver(resolver).open(text)) {
        Ok(Ok(stage)) => stage,
        Ok(Err(e)) => return Err(fail(None, format!("not a USD stage this reader can open: {e:#}"))),
        Err(()) => return Err(unreadable()),
    };
    // A layer the stage names and could not read (missing, not a regular file, too large)
    // would leave strands out without a word: it is an error.
    if let Some(error) = stage.composition_errors().first() {
        return Err(fail(None, format!("the stage could not be composed: {error}")));
    }
    match quietly(|| read_stage(&stage, read, limits)) {
        Ok(result) => result.map_err(|(place, message)| fail(place, message)),
        Err(()) => Err(unreadable()),
    }
}

/// The default resolver, opening only regular files within the strand-file size bound: a layer
/// the groom names (a sublayer, a reference) cannot be a FIFO, a device or an oversized file.
struct Guarded {
    inner: ar::DefaultResolver,
    max_bytes: u64,
}

impl ar::Resolver for Guarded {
    fn create_identifier(&self, asset_path: &str, anchor: Option<&ar::ResolvedPath>) -> String {
        self.inner.create_identifier(asset_path, anchor)
    }

    fn resolve(&self, asset_path: &str) -> Option<ar::ResolvedPath> {
        self.inner.resolve(asset_path)
    }

    fn resolve_for_new_asset(&self, _: &str) -> Option<ar::ResolvedPath> {
        None
    }

    fn open_asset(&self, resolved: &ar::ResolvedPath) -> std::io::Result<Box<dyn ar::Asset>> {
        // A layer inside a package (`groom.usdz[inner.usdc]`) is read from the package's file.
        let text = resolved.to_string_lossy();
        let file = text.split_once(".usdz[").map_or_else(|| text.to_string(), |(outer, _)| format!("{outer}.usdz"));
        let size = hikage_bundle::files::regular_metadata(Path::new(&file))?.len();
        if size > self.max_bytes {
            return Err(std::io::Error::other(format!("{file}: {size} bytes, above the limit of {}", self.max_bytes)));
        }
        self.inner.open_asset(resolved)
    }
}

thread_local! {
    /// Set while this thread runs the USD parser: its panics are reported as errors instead.
    static QUIET: Cell<bool> = const { Cell::new(false) };
}

/// Runs `f`, catching a panic, which is then not printed: the caller reports it as an error.
/// The panic hook is wrapped once; panics elsewhere, or on other threads, still reach the hook
/// that was there before.
fn quietly<T>(f: impl FnOnce() -> T) -> Result<T, ()> {
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !QUIET.with(Cell::get) {
                previous(info);
            }
        }));
    });
    let was = QUIET.with(|q| q.replace(true));
    let result = std::panic::catch_unwind(AssertUnwindSafe(f));
    QUIET.with(|q| q.set(was));
    result.map_err(drop)
}

fn read_stage(stage: &usd::Stage, read: &GroomRead, limits: &HairLimits) -> Result<(Strands, FileFrame), Problem> {
    let whole = |e: anyhow::Error| (None, format!("{e:#}"));
    let mut paths = Vec::new();
    stage.traverse(usd::PrimPredicate::default(), |p| paths.push(p.clone())).map_err(whole)?;
    // The job's time is in seconds; the stage's in time codes.
    let time = match read.time {
        None => None,
        Some(t) => Some(usd::TimeCode::new(
            t * stage_number(stage, "timeCodesPerSecond").map_err(whole)?.unwrap_or(24.0) as f64,
        )),
    };
    let (mut sets, mut points) = (Vec::new(), 0);
    for path in &paths {
        let Some(curves) = geom::BasisCurves::get(stage, path.clone()).map_err(whole)? else { continue };
        let set = read_curves(&curves, time, limits, points).map_err(|m| (Some(format!("prim {path}")), m))?;
        points += set.points.len() as u64;
        sets.push(set);
    }
    if sets.is_empty() {
        return Err((None, "no BasisCurves prim: expected a groom exported as USD curves".into()));
    }
    let out = curves::gather(sets, read.group, limits)?;
    let frame = FileFrame {
        meters_per_unit: stage_number(stage, "metersPerUnit").map_err(whole)?,
        up: match stage.stage_metadata("upAxis").map_err(whole)? {
            Some(sdf::Value::Token(t)) if t.as_str() == "Z" => Some(UpAxis::Z),
            Some(sdf::Value::Token(t)) if t.as_str() == "Y" => Some(UpAxis::Y),
            Some(other) => return Err((None, format!("upAxis {other:?}: expected \"Y\" or \"Z\""))),
            None => None,
        },
    };
    Ok((out, frame))
}

/// A number of the stage's metadata, when authored.
fn stage_number(stage: &usd::Stage, key: &str) -> anyhow::Result<Option<f32>> {
    Ok(match stage.stage_metadata(key)? {
        Some(sdf::Value::Double(v)) => Some(v as f32),
        Some(sdf::Value::Float(v)) => Some(v),
        _ => None,
    })
}

/// One prim's curves, in the stage's world frame, at `time` (else the default time).
fn read_curves(
    curves: &geom::BasisCurves,
    time: Option<usd::TimeCode>,
    limits: &HairLimits,
    before: u64,
) -> Result<CurveSet, String> {
    let e = |e: anyhow::Error| format!("{e:#}");
    let value = |attr: &usd::Attribute| value(attr, time).map_err(e);
    let counts = match value(&curves.curve_vertex_counts_attr())? {
        Some(sdf::Value::IntVec(c)) => c,
        Some(other) => return Err(format!("curveVertexCounts is {}: expected int[]", kind(&other))),
        None => return Err("no curveVertexCounts".into()),
    };
    let local = vectors(value(&curves.points_attr())?, "points")?.ok_or("no points")?;
    let counts: Vec<i64> = counts.iter().map(|&c| c as i64).collect();
    let counts = curves::check_counts(&counts, local.len() as u64, before, limits)?;
    let world = world_transform(curves.prim(), time.unwrap_or(usd::TimeCode::EARLIEST))?;
    let mut points = Vec::with_capacity(local.len());
    for (i, p) in local.iter().enumerate() {
        let q = world.transform_point(*p);
        if ![q.x, q.y, q.z].iter().all(|v| v.is_finite()) {
            return Err(format!("point {i} is ({}, {}, {}): expected finite coordinates", p.x, p.y, p.z));
        }
        points.push([q.x, q.y, q.z]);
    }
    // Widths are diameters in the prim's space: scaled by the transform's mean axis scale.
    let scale = {
        let axis = |v: Vec3f| (v.x * v.x + v.y * v.y + v.z * v.z).sqrt();
        let x = |x, y, z| world.transform_vec(Vec3f { x, y, z });
        (axis(x(1.0, 0.0, 0.0)) * axis(x(0.0, 1.0, 0.0)) * axis(x(0.0, 0.0, 1.0))).cbrt()
    };
    // Unreal's groom attributes, as Blender writes them (`primvars:groom_*`), before USD's own.
    let prim = curves.prim();
    let first = |names: [(&'static str, usd::Attribute); 2]| -> Result<_, String> {
        for (name, attr) in names {
            if let Some(v) = value(&attr)? {
                return Ok(Some((name, attr, v)));
            }
        }
        Ok(None)
    };
    let widths = match first([
        ("primvars:groom_width", prim.attribute("primvars:groom_width")),
        ("widths", curves.widths_attr()),
    ])? {
        None => None,
        Some((name, attr, sdf::Value::FloatVec(w))) => {
            let w = curves::spread(&w, interpolation(&attr, name)?, &counts, name)?;
            curves::check_widths(&w, name)?;
            Some(w.iter().map(|v| v * scale).collect())
        }
        Some((name, _, other)) => return Err(format!("{name} is {}: expected float[]", kind(&other))),
    };
    let colors = match first([
        ("primvars:groom_color", prim.attribute("primvars:groom_color")),
        ("primvars:displayColor", prim.attribute("primvars:displayColor")),
    ])? {
        None => None,
        Some((name, attr, v)) => {
            let c = colors(v, name)?;
            let c = curves::spread(&c, interpolation(&attr, name)?, &counts, name)?;
            curves::check_colors(&c, name)?;
            Some(c)
        }
    };
    let ints = |name: &str| -> Result<Option<Vec<i32>>, String> {
        match value(&prim.attribute(name))? {
            None => Ok(None),
            Some(sdf::Value::IntVec(v)) => curves::per_curve(&v, &counts, name).map(Some),
            Some(sdf::Value::Int(v)) => Ok(Some(vec![v; counts.len()])),
            Some(sdf::Value::BoolVec(v)) => {
                curves::per_curve(&v, &counts, name).map(|v| Some(v.iter().map(|&b| b as i32).collect()))
            }
            Some(other) => Err(format!("{name} is {}: expected int[]", kind(&other))),
        }
    };
    let guides = ints("primvars:groom_guide")?.map(|g| g.iter().map(|&v| v != 0).collect());
    let groups = ints("primvars:groom_group_id")?;
    Ok(CurveSet { counts, points, widths, colors, guides, groups })
}

/// An attribute's value at `time`; without one, at the default time, or its first time sample
/// when only samples are authored.
fn value(attr: &usd::Attribute, time: Option<usd::TimeCode>) -> anyhow::Result<Option<sdf::Value>> {
    if let Some(time) = time {
        return attr.get_at::<sdf::Value>(time);
    }
    match attr.get::<sdf::Value>()? {
        Some(v) => Ok(Some(v)),
        None => attr.get_at::<sdf::Value>(usd::TimeCode::EARLIEST),
    }
}

/// A colour value (`color3f[]`, `color4f[]` as Blender writes its colour attributes, doubles
/// narrowed), as linear RGB.
fn colors(value: sdf::Value, name: &str) -> Result<Vec<[f32; 3]>, String> {
    match value {
        sdf::Value::Vec4fVec(v) => Ok(v.iter().map(|c| [c.x, c.y, c.z]).collect()),
        other => Ok(vectors(Some(other), name)?.unwrap_or_default().iter().map(|c| [c.x, c.y, c.z]).collect()),
    }
}

/// A value of 3-vectors (`point3f[]`, `color3f[]`, `float3[]`; doubles narrowed to floats).
fn vectors(value: Option<sdf::Value>, name: &str) -> Result<Option<Vec<Vec3f>>, String> {
    match value {
        None => Ok(None),
        Some(sdf::Value::Vec3fVec(v)) => Ok(Some(v)),
        Some(sdf::Value::Vec3dVec(v)) => {
            Ok(Some(v.iter().map(|d| Vec3f { x: d.x as f32, y: d.y as f32, z: d.z as f32 }).collect()))
        }
        Some(other) => Err(format!("{name} is {}: expected an array of 3-vectors", kind(&other))),
    }
}

/// A value's type, for messages: its variant's name.
fn kind(value: &sdf::Value) -> String {
    let debug = format!("{value:?}");
    debug.split(['(', ' ', '{']).next().unwrap_or("a value").to_string()
}

/// A primvar's `interpolation` (`vertex` when not authored, as USD's fallback for widths on
/// curves says).
fn interpolation(attr: &usd::Attribute, name: &str) -> Result<Interpolation, String> {
    let token = attr.get_metadata::<openusd::tf::Token>("interpolation").map_err(|e| format!("{e:#}"))?;
    match token.as_ref().map_or("vertex", |t| t.as_str()) {
        "constant" => Ok(Interpolation::Constant),
        "uniform" => Ok(Interpolation::Uniform),
        "varying" => Ok(Interpolation::Varying),
        "vertex" => Ok(Interpolation::Vertex),
        other => Err(format!("{name} has interpolation {other:?}: expected constant, uniform, varying or vertex")),
    }
}

/// The transform from `prim`'s space to the stage's world (row vectors: `p · M`).
fn world_transform(prim: &Prim, time: usd::TimeCode) -> Result<Matrix4d, String> {
    let e = |e: anyhow::Error| format!("{e:#}");
    let mut m = Matrix4d::IDENTITY;
    let mut at = Some(prim.path().clone());
    while let Some(path) = at {
        if path.is_abs_root() {
            break;
        }
        let placed = Placed(prim.stage().prim(path.clone()));
        m = m * placed.local_to_parent_transform(time).map_err(e)?;
        if placed.resets_xform_stack().map_err(e)? {
            break;
        }
        at = path.parent();
    }
    Ok(m)
}
