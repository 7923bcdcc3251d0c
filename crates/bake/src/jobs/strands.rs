//! The `Strands` job: a `.hair` file or OBJ polylines → hair strip meshes (seed 004).

use std::path::{Path, PathBuf};

use hikage_bundle::{Settings, read_strand_points};
use serde::{Deserialize, Deserializer, Serialize};

use super::source::deserialize_flat;
use super::{BakedAsset, Baker, JobContext};
use crate::error::BakeError;
use crate::strands::strips::{self, StripSets};
use crate::strands::{self, Strands, UpAxis, auto, bind, ribbons};

/// Version of the strands job; part of the input hash. 3: point records (format 1.5), colour
/// settings, the visibility rule; 4: quantized ribbon streams (format 1.10); 5: binding to a
/// skinned scalp (format 1.11).
pub const ALGORITHM_VERSION: u32 = 5;

/// A strands bake. Asset ids: `<id>.strips`, `<id>.ribbons` with `ribbons`, and `<id>.binding`
/// with `<id>.scalp` with `scalp`.
///
/// Widths (full, world units) and opacities are those of a strand with the source's default
/// thickness and transparency; each strand's own values scale them. Absent: the shading set is
/// the source's defaults, the opacity set the shading set times the paper's ratios (width
/// × 1.40/0.16, opacity × 0.0165/0.366), unless `auto` chooses it.
///
/// With the `clap` feature it is also the `hikage strands` command line (the id comes from
/// `--id` or the input's file stem).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct StrandsJob {
    /// Prefix of the asset ids.
    #[cfg_attr(feature = "clap", arg(skip))]
    pub id: String,
    /// A USD groom (`.usd`, `.usda`, `.usdc`, `.usdz`: every `BasisCurves` prim), an Alembic
    /// groom (`.abc`: every curves object), a Cem Yuksel `.hair` file (by its signature) or
    /// Wavefront OBJ with `l` polylines.
    pub input: PathBuf,
    /// The job's own settings.
    #[cfg_attr(feature = "clap", command(flatten))]
    pub options: StrandsOptions,
}

/// The `Strands` job's own settings; every default is [`StrandsOptions::default`]'s.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct StrandsOptions {
    /// Shading set width (default: the input's default thickness).
    #[cfg_attr(feature = "clap", arg(long))]
    pub shading_width: Option<f32>,
    /// Shading set opacity (default: 1 − the input's default transparency).
    #[cfg_attr(feature = "clap", arg(long))]
    pub shading_alpha: Option<f32>,
    /// Opacity set width (default: shading width × 1.40/0.16, the paper's ratio).
    #[cfg_attr(feature = "clap", arg(long))]
    pub opacity_width: Option<f32>,
    /// Opacity set opacity (default: shading opacity × 0.0165/0.366).
    #[cfg_attr(feature = "clap", arg(long))]
    pub opacity_alpha: Option<f32>,
    /// Choose the opacity set for an opacity map of N² texels: the width (with width × opacity
    /// kept) whose light-space shadow is nearest the shading set's at 8× the resolution.
    #[cfg_attr(feature = "clap", arg(long, value_name = "N", num_args = 0..=1, default_missing_value = "256"))]
    pub auto: Option<u32>,
    /// Share of the width lost at the tip, 0–1.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = StrandsOptions::default().taper))]
    pub taper: f32,
    /// Also bake a fixed-orientation ribbon mesh (minimum-twist frames).
    #[cfg_attr(feature = "clap", arg(long))]
    pub ribbons: bool,
    /// Linear RGB (0–1) of every strand, in place of the file's colours.
    #[cfg_attr(feature = "clap", arg(long, value_name = "R,G,B", value_parser = parse_rgb))]
    pub color: Option<[f32; 3]>,
    /// Linear RGB at the root: a gradient toward the tip's (`tip_color`, else `color`, else
    /// the file's), in place of the file's colours.
    #[cfg_attr(feature = "clap", arg(long, value_name = "R,G,B", value_parser = parse_rgb))]
    pub root_color: Option<[f32; 3]>,
    /// Linear RGB at the tip (see `root_color`).
    #[cfg_attr(feature = "clap", arg(long, value_name = "R,G,B", value_parser = parse_rgb))]
    pub tip_color: Option<[f32; 3]>,
    /// A skinned glTF (`.glb`/`.gltf`) to bind each strand's root to: the mesh of its first
    /// skinned node, in the hair's own frame (bind pose). Adds `<id>.binding` (the nearest
    /// triangle and barycentric weights, 8 bytes a strand) and `<id>.scalp` (the triangles bound
    /// to, with their joints and weights); at run time each strand follows its triangle rigidly.
    #[cfg_attr(feature = "clap", arg(long, value_name = "GLTF"))]
    pub scalp: Option<PathBuf>,
    /// The farthest a root may lie from the scalp, world units (default: 2% of the hair's
    /// bounding-box diagonal); a root farther away is an error naming the strand.
    #[cfg_attr(feature = "clap", arg(long, value_name = "DISTANCE"))]
    pub scalp_distance: Option<f32>,
    /// Metres per unit of the input's coordinates and widths: the strands are scaled by it
    /// (default: the file's own, USD `metersPerUnit`; 1 for Alembic, `.hair` and OBJ, which do
    /// not say).
    #[cfg_attr(feature = "clap", arg(long, value_name = "METRES"))]
    pub units: Option<f32>,
    /// The input's up axis, turned into the bundle's +Y (default: the file's own, USD `upAxis`;
    /// Y for Alembic, `.hair` and OBJ).
    #[cfg_attr(feature = "clap", arg(long, value_enum))]
    pub up: Option<UpAxis>,
    /// The time to read from a USD or Alembic groom, seconds: Alembic's sample nearest it, USD's
    /// value at it (interpolated between samples, as USD does); default: the file's default
    /// time, or its first sample.
    #[cfg_attr(feature = "clap", arg(long, value_name = "SECONDS"))]
    pub time: Option<f64>,
    /// Bake only this group of a groom (Unreal's `groom_group_id`; strands without one are
    /// group 0): one job per group gives one asset per group (default: every group, one asset).
    #[cfg_attr(feature = "clap", arg(long, value_name = "ID"))]
    pub group: Option<i32>,
    /// Payload compression: `Auto` (a zstd level per kind of payload, `--zstd auto`), `Zstd(level)`
    /// (1–22), or `None` (`--zstd 0`).
    #[cfg_attr(
        feature = "clap",
        arg(long = "zstd", value_name = "LEVEL", value_parser = crate::compression::parse_level, default_value = "auto")
    )]
    pub compression: crate::Compression,
}

/// `R,G,B` on the command line.
#[cfg(feature = "clap")]
fn parse_rgb(text: &str) -> Result<[f32; 3], String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [r, g, b] = parts.as_slice() else {
        return Err(format!("expected three numbers R,G,B, found {text:?}"));
    };
    let num = |t: &str| t.parse::<f32>().map_err(|e| format!("{t:?}: {e}"));
    Ok([num(r)?, num(g)?, num(b)?])
}

impl<'de> Deserialize<'de> for StrandsJob {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (id, input, options) = deserialize_flat(d, "Strands")?;
        Ok(StrandsJob { id, input, options })
    }
}

impl StrandsJob {
    /// A job with every setting at its default.
    pub fn new(id: &str, input: PathBuf) -> StrandsJob {
        StrandsJob { id: id.into(), input, options: StrandsOptions::default() }
    }

    /// Id of the strip mesh.
    pub fn strips_id(&self) -> String {
        format!("{}.strips", self.id)
    }

    /// Id of the ribbon mesh.
    pub fn ribbons_id(&self) -> String {
        format!("{}.ribbons", self.id)
    }

    /// Id of the strands' binding to the scalp.
    pub fn binding_id(&self) -> String {
        format!("{}.binding", self.id)
    }

    /// Id of the scalp the strands are bound to.
    pub fn scalp_id(&self) -> String {
        format!("{}.scalp", self.id)
    }

    /// The binding of `s` to the scalp, when the job has one: the assets `<id>.binding` and
    /// `<id>.scalp`. `pad` is the widest half strip width (for the scalp's reach).
    fn bind(&self, s: &Strands, pad: f32, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        let Some(scalp) = &self.options.scalp else { return Ok(Vec::new()) };
        let path = ctx.base_dir.join(scalp);
        let mesh = crate::mesh::gltf::load_skinned(&path, crate::mesh::MeshLimits::default())?;
        let (mut lo, mut hi) = (glam::Vec3::splat(f32::INFINITY), glam::Vec3::splat(f32::NEG_INFINITY));
        for &p in &s.points {
            (lo, hi) = (lo.min(p.into()), hi.max(p.into()));
        }
        let limit = self.options.scalp_distance.unwrap_or(0.02 * (hi - lo).length().max(0.0));
        let bound = bind::bind(s, &mesh, limit as f64, pad).map_err(|far| {
            let how = match far.distance {
                Some(d) => format!("lies {d:.6} from the scalp's nearest point"),
                None => "has no scalp triangle near it".into(),
            };
            BakeError::input(
                ctx.base_dir.join(&self.input),
                Some(format!("strand {}", far.strand)),
                format!(
                    "its root {how}, farther than {limit} (the hair and {} must share the bind pose's frame; set scalp_distance to allow more)",
                    scalp.display()
                ),
            )
        })?;
        let binding = hikage_bundle::binding::binding_mesh(&bound.bindings)?;
        let scalp_mesh = bound.scalp.to_mesh()?;
        Ok(vec![
            BakedAsset {
                id: self.binding_id(),
                settings: Settings::HairBinding(hikage_bundle::HairBindingSettings {
                    strands: self.strips_id(),
                    scalp: self.scalp_id(),
                    max_distance: bound.max_distance,
                }),
                payload: binding.into(),
            },
            BakedAsset {
                id: self.scalp_id(),
                settings: Settings::Scalp(hikage_bundle::ScalpSettings {
                    joints: mesh.joint_names,
                    source_triangles: mesh.triangles.len() as u32,
                }),
                payload: scalp_mesh.into(),
            },
        ])
    }

    /// The sets the job asks for on this source.
    pub fn sets(&self, s: &Strands) -> StripSets {
        let source = StripSets::from_source(s);
        let shading = (
            self.options.shading_width.unwrap_or(source.shading.0),
            self.options.shading_alpha.unwrap_or(source.shading.1),
        );
        let opacity = (
            self.options.opacity_width.unwrap_or(shading.0 * strips::PAPER_WIDTH_RATIO),
            self.options.opacity_alpha.unwrap_or(shading.1 * strips::PAPER_ALPHA_RATIO),
        );
        StripSets { shading, opacity, taper: self.options.taper }
    }

    /// The input's strands in the bundle's frame: scaled by `units` (else the file's metres per
    /// unit, else 1) and turned from `up` (else the file's up axis, else Y) to +Y.
    pub fn load(&self, path: &Path) -> Result<Strands, BakeError> {
        let read = strands::GroomRead { time: self.options.time, group: self.options.group };
        let (mut s, frame) = strands::load_groom(path, &read)?;
        let units = self.options.units.or(frame.meters_per_unit).unwrap_or(1.0);
        let up = self.options.up.or(frame.up).unwrap_or(UpAxis::Y);
        if units != 1.0 {
            s.points.iter_mut().flatten().for_each(|c| *c *= units);
            s.thickness.iter_mut().flatten().for_each(|t| *t *= units);
            s.default_thickness *= units;
        }
        if up == UpAxis::Z {
            s.points.iter_mut().for_each(|p| *p = [p[0], p[2], -p[1]]);
        }
        Ok(s)
    }

    /// The colour settings applied to `s`: with any of `color`, `root_color`, `tip_color`, every
    /// point's colour is the root's mixed toward the tip's by `param`, each end the setting
    /// given for it, else `color`, else the file's colour at that point.
    pub fn apply_colors(&self, s: &mut Strands) {
        let o = &self.options;
        if o.color.is_none() && o.root_color.is_none() && o.tip_color.is_none() {
            return;
        }
        let starts = strips::strand_starts(s);
        let mut colors = Vec::with_capacity(s.points.len());
        for (strand, &segments) in s.segments.iter().enumerate() {
            for i in 0..=segments as usize {
                let own = s.color.as_ref().map_or(s.default_color, |c| c[starts[strand] + i]);
                let root = o.root_color.or(o.color).unwrap_or(own);
                let tip = o.tip_color.or(o.color).unwrap_or(own);
                let t = if segments == 0 { 0.0 } else { i as f32 / segments as f32 };
                colors.push(std::array::from_fn(|k| root[k] + (tip[k] - root[k]) * t));
            }
        }
        s.color = Some(colors);
    }

    /// The rule for strands no one could see: refused with the value, where it came from and
    /// the settings that fix it — no width, wider than a tenth of the hair's bounding box, or
    /// no opacity at any point.
    fn check_visible(&self, s: &Strands, sets: &StripSets, path: &Path) -> Result<(), BakeError> {
        let (width_from, alpha_from) = (
            match (self.options.shading_width, &s.thickness) {
                (Some(_), _) => "the shading_width setting",
                (None, Some(_)) => "the per-point thickness",
                (None, None) => "the header's default thickness",
            },
            match (self.options.shading_alpha, &s.transparency) {
                (Some(_), _) => "the shading_alpha setting",
                (None, Some(_)) => "the per-point transparency",
                (None, None) => "the header's default transparency",
            },
        );
        let thick_ref = s.default_thickness;
        let ratio = |p: usize| match (&s.thickness, thick_ref > 0.0) {
            (Some(t), true) => t[p] / thick_ref,
            _ => 1.0,
        };
        let widest = (0..s.points.len()).map(|p| sets.shading.0 * ratio(p)).fold(0.0f32, f32::max);
        let (mut lo, mut hi) = (glam::Vec3::splat(f32::INFINITY), glam::Vec3::splat(f32::NEG_INFINITY));
        for &p in &s.points {
            (lo, hi) = (lo.min(p.into()), hi.max(p.into()));
        }
        let diagonal = if s.points.is_empty() { 0.0 } else { (hi - lo).length() };
        let fix = "set shading_width (world units) and shading_alpha in the job";
        if !(widest > 0.0 && widest.is_finite()) {
            return Err(BakeError::input(
                path,
                Some(width_from.into()),
                format!("strands {widest} wide cannot be seen; {fix}"),
            ));
        }
        if diagonal > 0.0 && widest > 0.1 * diagonal {
            return Err(BakeError::input(
                path,
                Some(width_from.into()),
                format!(
                    "strands up to {widest} wide are wider than a tenth of the hair's {diagonal:.4}-wide bounding box (expected hair thinner than the head it grows on); {fix}"
                ),
            ));
        }
        let alpha_ref = 1.0 - s.default_transparency;
        let visible = (0..s.points.len()).any(|p| {
            let own = 1.0 - s.transparency.as_ref().map_or(s.default_transparency, |t| t[p]);
            let k = if alpha_ref > 0.0 { own / alpha_ref } else { 1.0 };
            sets.shading.1 * k > 0.0
        });
        if !s.points.is_empty() && !visible {
            return Err(BakeError::input(
                path,
                Some(alpha_from.into()),
                format!("every strand has opacity 0 (shading opacity {}); {fix}", sets.shading.1),
            ));
        }
        Ok(())
    }
}

impl Baker for StrandsJob {
    fn id(&self) -> &str {
        &self.id
    }

    fn kind(&self) -> &'static str {
        "strands"
    }

    fn algorithm_version(&self) -> u32 {
        ALGORITHM_VERSION
    }

    fn inputs(&self, base_dir: &Path) -> Vec<PathBuf> {
        let mut inputs = vec![base_dir.join(&self.input)];
        if let Some(scalp) = &self.options.scalp {
            let scalp = base_dir.join(scalp);
            inputs.extend(crate::mesh::gltf::external_files(&scalp));
            inputs.insert(1, scalp);
        }
        inputs
    }

    fn outputs(&self) -> Vec<String> {
        let mut out = vec![self.strips_id()];
        if self.options.ribbons {
            out.push(self.ribbons_id());
        }
        if self.options.scalp.is_some() {
            out.extend([self.binding_id(), self.scalp_id()]);
        }
        out
    }

    fn canonical_settings(&self) -> String {
        // The frame settings join the hash only when set, so jobs without them keep theirs.
        let frame = match (self.options.units, self.options.up) {
            (None, None) => String::new(),
            (units, up) => format!(";units={units:?};up={up:?}"),
        };
        let settings = format!(
            "shading=({:?},{:?});opacity=({:?},{:?});auto={:?};taper={:?};ribbons={};color={:?};root={:?};tip={:?};scalp={};scalp_distance={:?}",
            self.options.shading_width,
            self.options.shading_alpha,
            self.options.opacity_width,
            self.options.opacity_alpha,
            self.options.auto,
            self.options.taper,
            self.options.ribbons,
            self.options.color,
            self.options.root_color,
            self.options.tip_color,
            self.options.scalp.is_some(),
            self.options.scalp_distance
        );
        settings + &frame
    }

    fn check(&self) -> Result<(), String> {
        for (name, w) in [("shading_width", self.options.shading_width), ("opacity_width", self.options.opacity_width)]
        {
            if let Some(w) = w
                && !(w.is_finite() && w > 0.0)
            {
                return Err(format!("{name} must be finite and above 0, found {w}"));
            }
        }
        for (name, a) in [("shading_alpha", self.options.shading_alpha), ("opacity_alpha", self.options.opacity_alpha)]
        {
            if let Some(a) = a
                && !(a > 0.0 && a <= 1.0)
            {
                return Err(format!("{name} must be in (0, 1], found {a}"));
            }
        }
        for (name, c) in [
            ("color", self.options.color),
            ("root_color", self.options.root_color),
            ("tip_color", self.options.tip_color),
        ] {
            if let Some(c) = c
                && !c.iter().all(|x| (0.0..=1.0).contains(x))
            {
                return Err(format!("{name} must be linear RGB in [0, 1], found {c:?}"));
            }
        }
        if let Some(d) = self.options.scalp_distance
            && !(d.is_finite() && d >= 0.0)
        {
            return Err(format!("scalp_distance must be finite and not negative, found {d}"));
        }
        if self.options.scalp_distance.is_some() && self.options.scalp.is_none() {
            return Err("scalp_distance is set but no scalp is given".into());
        }
        if let Some(u) = self.options.units
            && !(u.is_finite() && u > 0.0)
        {
            return Err(format!("units must be a finite number of metres above 0, found {u}"));
        }
        if let Some(t) = self.options.time
            && !t.is_finite()
        {
            return Err(format!("time must be a finite number of seconds, found {t}"));
        }
        if !(0.0..=1.0).contains(&self.options.taper) {
            return Err(format!("taper must be in [0, 1], found {}", self.options.taper));
        }
        if let Some(r) = self.options.auto {
            if !(16..=8192).contains(&r) {
                return Err(format!("auto resolution must be 16–8192, found {r}"));
            }
            if self.options.opacity_width.is_some() || self.options.opacity_alpha.is_some() {
                return Err("auto chooses the opacity set: give either auto or opacity_width/opacity_alpha".into());
            }
        }
        Ok(())
    }

    fn check_inputs(&self, ctx: &JobContext) -> Result<(), BakeError> {
        let path = ctx.base_dir.join(&self.input);
        let s = self.load(&path)?;
        let sets = self.sets(&s);
        self.check_visible(&s, &sets, &path)?;
        self.bind(&s, 0.0, ctx).map(drop)
    }

    fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        (ctx.progress)(0, 2);
        let path = ctx.base_dir.join(&self.input);
        let mut s = self.load(&path)?;
        self.apply_colors(&mut s);
        let mut sets = self.sets(&s);
        self.check_visible(&s, &sets, &path)?;
        if let Some(resolution) = self.options.auto {
            sets = auto::choose(&s, &sets, resolution).0;
        }
        (ctx.progress)(1, 2);
        let strips = strips::build(&s, &sets);
        let settings = strips.settings(&s, &sets, self.options.auto);
        let ribbons = self.options.ribbons.then(|| {
            let points = read_strand_points(&strips.mesh, &settings).expect("the records were just built");
            ribbons::build(&points, sets.taper)
        });
        let mut out = vec![BakedAsset {
            id: self.strips_id(),
            settings: Settings::Strands(settings),
            payload: strips.mesh.into(),
        }];
        if let Some(mesh) = ribbons {
            out.push(BakedAsset { id: self.ribbons_id(), settings: Settings::Generic, payload: mesh.into() });
        }
        let widest = match &out[0].settings {
            Settings::Strands(st) => st.max_width * (sets.opacity.0 / sets.shading.0).max(1.0),
            _ => unreachable!("the strips come first"),
        };
        out.extend(self.bind(&s, 0.5 * widest, ctx)?);
        (ctx.progress)(2, 2);
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Colour settings: a root and a tip colour make a gradient along each strand by its
    /// param; `color` alone paints every point; the file's colours stay without either.
    #[test]
    fn colour_settings_make_a_root_to_tip_gradient() {
        let strands = || Strands {
            segments: vec![2, 0],
            points: vec![[0.0; 3], [0.0, 1.0, 0.0], [0.0, 2.0, 0.0], [1.0, 0.0, 0.0]],
            thickness: None,
            transparency: None,
            color: Some(vec![[0.1, 0.2, 0.3]; 4]),
            default_thickness: 0.01,
            default_transparency: 0.5,
            default_color: [0.5; 3],
        };
        let mut job = StrandsJob::new("h", "h.hair".into());
        let mut s = strands();
        job.apply_colors(&mut s);
        assert_eq!(s, strands(), "no setting leaves the file's colours");
        job.options.root_color = Some([1.0, 0.0, 0.0]);
        job.options.tip_color = Some([0.0, 0.0, 1.0]);
        job.apply_colors(&mut s);
        assert_eq!(s.color.unwrap(), vec![[1.0, 0.0, 0.0], [0.5, 0.0, 0.5], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]);
        let mut s = strands();
        job.options = StrandsOptions { color: Some([0.2, 0.4, 0.6]), tip_color: Some([1.0; 3]), ..Default::default() };
        job.apply_colors(&mut s);
        let got = s.color.unwrap();
        for (p, want) in [[0.2, 0.4, 0.6], [0.6, 0.7, 0.8], [1.0, 1.0, 1.0]].iter().enumerate() {
            assert!((0..3).all(|k| (got[p][k] - want[k]).abs() < 1e-6), "point {p}: {:?}", got[p]);
        }
        job.options.color = Some([2.0, 0.0, 0.0]);
        assert!(job.check().unwrap_err().contains("color"));
        job.options = StrandsOptions { time: Some(f64::NAN), ..Default::default() };
        assert!(job.check().unwrap_err().contains("time must be a finite number of seconds"));
    }
}
