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

use super::cyhair::HairLimits;
use super::{FileFrame, Strands, UpAxis};
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
pub fn load(path: &Path, limits: &HairLimits) -> Result<(Strands, FileFrame), BakeError> {
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
    match quietly(|| read_stage(&stage, limits)) {
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

/// What is wrong, and at which prim (or `None`: the file).
type Problem = (Option<String>, String);

fn read_stage(stage: &usd::Stage, limits: &HairLimits) -> Result<(Strands, FileFrame), Problem> {
    let whole = |e: anyhow::Error| (None, format!("{e:#}"));
    let mut paths = Vec::new();
    stage.traverse(usd::PrimPredicate::default(), |p| paths.push(p.clone())).map_err(whole)?;
    let mut out = Strands {
        segments: Vec::new(),
        points: Vec::new(),
        thickness: Some(Vec::new()),
        transparency: None,
        color: Some(Vec::new()),
        default_thickness: 0.0,
        default_transparency: 0.0,
        default_color: [1.0; 3],
    };
    let (mut widths_everywhere, mut colors_everywhere, mut prims) = (true, true, 0);
    for path in &paths {
        let Some(curves) = geom::BasisCurves::get(stage, path.clone()).map_err(whole)? else { continue };
        prims += 1;
        let at = |message: String| (Some(format!("prim {path}")), message);
        let got = read_curves(&curves, limits, out.points.len() as u64).map_err(at)?;
        out.segments.extend(got.counts.iter().map(|&n| (n - 1) as u16));
        out.points.extend(got.points);
        match got.widths {
            Some(w) => out.thickness.get_or_insert_with(Vec::new).extend(w),
            None => widths_everywhere = false,
        }
        match got.colors {
            Some(c) => out.color.get_or_insert_with(Vec::new).extend(c),
            None => colors_everywhere = false,
        }
    }
    if prims == 0 {
        return Err((None, "no BasisCurves prim: expected a groom exported as USD curves".into()));
    }
    if out.segments.len() as u64 > limits.max_strands {
        return Err((None, format!("{} strands, above the limit of {}", out.segments.len(), limits.max_strands)));
    }
    // A stage whose prims disagree (widths on some only) keeps what every prim has.
    if !widths_everywhere {
        out.thickness = None;
    }
    // The job's widths are a strand of the default thickness's: the widest point's, so the
    // shading set's width is the groom's widest and every point's own scales it.
    out.default_thickness = out.thickness.iter().flatten().fold(0.0, |m: f32, &w| m.max(w));
    if !colors_everywhere {
        out.color = None;
    }
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

/// One prim's curves, in the stage's world frame.
struct Read {
    counts: Vec<usize>,
    points: Vec<[f32; 3]>,
    widths: Option<Vec<f32>>,
    colors: Option<Vec<[f32; 3]>>,
}

fn read_curves(curves: &geom::BasisCurves, limits: &HairLimits, before: u64) -> Result<Read, String> {
    let e = |e: anyhow::Error| format!("{e:#}");
    let counts = match value(&curves.curve_vertex_counts_attr()).map_err(e)? {
        Some(sdf::Value::IntVec(c)) => c,
        Some(other) => return Err(format!("curveVertexCounts is {}: expected int[]", kind(&other))),
        None => return Err("no curveVertexCounts".into()),
    };
    let local = vectors(value(&curves.points_attr()).map_err(e)?, "points")?.ok_or("no points")?;
    let total: u64 = counts.iter().map(|&c| c.max(0) as u64).sum();
    if before + total > limits.max_points {
        return Err(format!("{} points in all, above the limit of {}", before + total, limits.max_points));
    }
    if total != local.len() as u64 {
        return Err(format!("curveVertexCounts add up to {total} points, but points holds {}", local.len()));
    }
    if let Some((i, &c)) = counts.iter().enumerate().find(|(_, c)| !(2..=65536).contains(*c)) {
        return Err(format!("curve {i} has {c} points: expected 2 to 65536"));
    }
    let counts: Vec<usize> = counts.iter().map(|&c| c as usize).collect();
    let world = world_transform(curves.prim())?;
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
    let widths_attr = curves.widths_attr();
    let widths = match value(&widths_attr).map_err(e)? {
        None => None,
        Some(sdf::Value::FloatVec(w)) => {
            let w = spread(&w, &interpolation(&widths_attr)?, &counts, "widths")?;
            if let Some((i, v)) = w.iter().enumerate().find(|(_, v)| !(v.is_finite() && **v >= 0.0)) {
                return Err(format!("width {i} is {v}: expected a finite width of 0 or more"));
            }
            Some(w.iter().map(|v| v * scale).collect())
        }
        Some(other) => return Err(format!("widths is {}: expected float[]", kind(&other))),
    };
    let color_attr = curves.prim().attribute("primvars:displayColor");
    let colors = match vectors(value(&color_attr).map_err(e)?, "primvars:displayColor")? {
        None => None,
        Some(c) => {
            let c: Vec<[f32; 3]> = c.iter().map(|v| [v.x, v.y, v.z]).collect();
            let c = spread(&c, &interpolation(&color_attr)?, &counts, "primvars:displayColor")?;
            if let Some((i, v)) = c.iter().enumerate().find(|(_, v)| !v.iter().all(|c| c.is_finite())) {
                return Err(format!("displayColor {i} is {v:?}: expected finite components"));
            }
            Some(c)
        }
    };
    Ok(Read { counts, points, widths, colors })
}

/// An attribute's value at the default time, or its first time sample when only samples are
/// authored.
fn value(attr: &usd::Attribute) -> anyhow::Result<Option<sdf::Value>> {
    match attr.get::<sdf::Value>()? {
        Some(v) => Ok(Some(v)),
        None => attr.get_at::<sdf::Value>(usd::TimeCode::EARLIEST),
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
fn interpolation(attr: &usd::Attribute) -> Result<String, String> {
    let token = attr.get_metadata::<openusd::tf::Token>("interpolation").map_err(|e| format!("{e:#}"))?;
    Ok(token.map_or_else(|| "vertex".into(), |t| t.as_str().to_string()))
}

/// Values of a primvar given at `interpolation`, one per point of curves of `counts` points.
fn spread<T: Copy>(values: &[T], interpolation: &str, counts: &[usize], name: &str) -> Result<Vec<T>, String> {
    let points: usize = counts.iter().sum();
    let wrong = |want: usize| {
        format!("{name} holds {} values for {interpolation} interpolation, expected {want}", values.len())
    };
    match interpolation {
        "constant" => match values {
            [v] => Ok(vec![*v; points]),
            _ => Err(wrong(1)),
        },
        "uniform" if values.len() == counts.len() => {
            Ok(counts.iter().zip(values).flat_map(|(&n, v)| std::iter::repeat_n(*v, n)).collect())
        }
        "uniform" => Err(wrong(counts.len())),
        // Varying values sit at segment ends; with control points taken as points, they are
        // the points' own when there is one a point.
        "vertex" | "varying" if values.len() == points => Ok(values.to_vec()),
        "vertex" | "varying" => Err(wrong(points)),
        other => Err(format!("{name} has interpolation {other:?}: expected constant, uniform, varying or vertex")),
    }
}

/// The transform from `prim`'s space to the stage's world (row vectors: `p · M`).
fn world_transform(prim: &Prim) -> Result<Matrix4d, String> {
    let e = |e: anyhow::Error| format!("{e:#}");
    let mut m = Matrix4d::IDENTITY;
    let mut at = Some(prim.path().clone());
    while let Some(path) = at {
        if path.is_abs_root() {
            break;
        }
        let placed = Placed(prim.stage().prim(path.clone()));
        m = m * placed.local_to_parent_transform(usd::TimeCode::EARLIEST).map_err(e)?;
        if placed.resets_xform_stack().map_err(e)? {
            break;
        }
        at = path.parent();
    }
    Ok(m)
}
