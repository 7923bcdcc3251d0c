//! What changed between two bakes, in each method's own terms: [`diff`] compares two bundles
//! asset by asset and measures each change as a player would see it (horizon angles and sun
//! tests that flip, metres of height, texels of relief depth, …), against [`Tolerances`].
//!
//! Byte hashes change for harmless reasons (a new encoder, a new job version); a payload that
//! decodes to the same values measures 0 and passes any tolerance.

use serde::{Deserialize, Serialize};

use crate::{Asset, AssetKind, Bundle, BundleError, Settings, TextureData};

/// Sun elevations of the fixed set of sun tests a horizon change is measured with, degrees:
/// every texel at every stored azimuth under each.
pub const SUN_ELEVATIONS: [f32; 5] = [2.0, 5.0, 10.0, 20.0, 30.0];

/// One tolerance, defined once for the library, `hikage diff`'s flags and a pipeline's
/// `tolerances`: its name (the field and the pipeline's key), its flag, the unit its value is
/// counted in, what it bounds, and its field of [`Tolerances`].
#[derive(Clone, Copy, Debug)]
pub struct Tolerance {
    /// The name in a pipeline's `tolerances` and the field of [`Tolerances`].
    pub name: &'static str,
    /// `hikage diff`'s flag (`--<flag>`).
    pub flag: &'static str,
    /// What the value is counted in, for a flag's help.
    pub unit: &'static str,
    /// What it bounds, as a help line (no final stop).
    pub doc: &'static str,
    /// Its field.
    pub field: fn(&mut Tolerances) -> &mut f32,
}

/// Every tolerance, in the order reports list them.
pub const TOLERANCES: [Tolerance; 9] = [
    Tolerance {
        name: "horizon_degrees",
        flag: "horizon-degrees",
        unit: "DEGREES",
        doc: "Largest change of a horizon angle, degrees",
        field: |t| &mut t.horizon_degrees,
    },
    Tolerance {
        name: "sun_flips",
        flag: "sun-flips",
        unit: "SHARE",
        doc: "Share (0–1) of the sun tests (2°, 5°, 10°, 20°, 30° at every azimuth and texel) that may flip between \
              lit and shadowed",
        field: |t| &mut t.sun_flips,
    },
    Tolerance {
        name: "distance_texels",
        flag: "distance-texels",
        unit: "TEXELS",
        doc: "Largest change of a horizon's distance, texels",
        field: |t| &mut t.distance_texels,
    },
    Tolerance {
        name: "height",
        flag: "height",
        unit: "UNITS",
        doc: "Largest change of a height, world units",
        field: |t| &mut t.height,
    },
    Tolerance {
        name: "ao",
        flag: "ao",
        unit: "AO",
        doc: "Largest change of ambient occlusion (0–1)",
        field: |t| &mut t.ao,
    },
    Tolerance {
        name: "relief_texels",
        flag: "relief-texels",
        unit: "TEXELS",
        doc: "Largest change of a relief depth, deeper or shallower, texels",
        field: |t| &mut t.relief_texels,
    },
    Tolerance {
        name: "curvature",
        flag: "curvature",
        unit: "SHARE",
        doc: "Largest relative change of a principal curvature",
        field: |t| &mut t.curvature,
    },
    Tolerance {
        name: "point_move",
        flag: "point-move",
        unit: "UNITS",
        doc: "Largest move of a strand point or mesh vertex, world units",
        field: |t| &mut t.point_move,
    },
    Tolerance {
        name: "value",
        flag: "value",
        unit: "VALUE",
        doc: "Largest change of any other value: max-mip pyramids, plain textures, and mesh streams other than \
              positions and curvature",
        field: |t| &mut t.value,
    },
];

/// How far each measure may move before a change is beyond tolerance. All 0 by default: any
/// change of a decoded value fails. Set in a pipeline's `tolerances` or by `hikage diff`'s flags.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Tolerances {
    /// Largest change of a horizon angle, degrees.
    pub horizon_degrees: f32,
    /// Share (0–1) of the sun tests ([`SUN_ELEVATIONS`] at every azimuth and texel) that may
    /// flip between lit and shadowed.
    pub sun_flips: f32,
    /// Largest change of a horizon's distance, texels.
    pub distance_texels: f32,
    /// Largest change of a height, world units.
    pub height: f32,
    /// Largest change of ambient occlusion (0–1).
    pub ao: f32,
    /// Largest change of a relief depth, deeper or shallower, texels.
    pub relief_texels: f32,
    /// Largest relative change of a principal curvature.
    pub curvature: f32,
    /// Largest move of a strand point or mesh vertex, world units.
    pub point_move: f32,
    /// Largest change of any other value: max-mip pyramids, plain textures, and mesh streams
    /// other than positions and curvature.
    pub value: f32,
}

impl Tolerances {
    /// Each tolerance with its name, as a pipeline's `tolerances` spells it.
    pub fn named(&self) -> [(&'static str, f32); 9] {
        TOLERANCES.map(|t| (t.name, *(t.field)(&mut self.clone())))
    }

    /// The first tolerance that is not a finite number ≥ 0, as a message naming it: NaN would
    /// turn the gate off and a negative one would fail every comparison.
    pub fn check(&self) -> Result<(), String> {
        match self.named().into_iter().find(|(_, v)| !(v.is_finite() && *v >= 0.0)) {
            Some((name, v)) => Err(format!("{name} must be a finite number ≥ 0 (a tolerance), found {v}")),
            None => Ok(()),
        }
    }
}

/// Whether an asset is in both bundles and what became of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// The same payload and settings (or values that decode the same).
    Same,
    /// Only in the new bundle.
    Added,
    /// Only in the old bundle.
    Removed,
    /// In both, with different values.
    Changed,
}

/// One figure of a change.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Measure {
    /// What is measured, e.g. `horizon angle max`.
    pub name: String,
    /// The figure.
    pub value: f64,
    /// Its unit, e.g. `°`, `texels`, `m` (empty for a share or a count).
    pub unit: &'static str,
    /// The tolerance it is held to, if it is held to one (counts and percentiles are not).
    pub limit: Option<f64>,
    /// Where the largest change is, e.g. `texel (12, 40), direction 3`.
    pub at: Option<String>,
}

impl Measure {
    /// True when the figure is above its tolerance.
    pub fn beyond(&self) -> bool {
        self.limit.is_some_and(|l| self.value > l)
    }
}

/// What became of one asset.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AssetDiff {
    /// The asset id.
    pub id: String,
    /// Its kind (the new one where both exist).
    pub kind: AssetKind,
    /// In both, added or removed, the same or changed.
    pub status: Status,
    /// The figures of a change.
    pub measures: Vec<Measure>,
    /// Why the two cannot be compared value by value (a new size, a new kind), if so: always
    /// beyond tolerance.
    pub note: Option<String>,
}

impl AssetDiff {
    /// True when the asset was added or removed, cannot be compared, or a figure is beyond its
    /// tolerance.
    pub fn beyond(&self) -> bool {
        matches!(self.status, Status::Added | Status::Removed)
            || self.note.is_some()
            || self.measures.iter().any(Measure::beyond)
    }
}

/// Every asset of `old` and `new`, in id order, each measured against `tolerances`. Payloads
/// with the same BLAKE3 and settings are not read; others are read (sizes and hashes checked)
/// and decoded.
///
/// ```no_run
/// use hikage_bundle::Bundle;
/// use hikage_bundle::diff::{Tolerances, diff};
///
/// let (old, new) = (Bundle::open("release/bundle".as_ref())?, Bundle::open("bundle".as_ref())?);
/// let tolerances = Tolerances { horizon_degrees: 0.5, sun_flips: 0.001, ..Tolerances::default() };
/// for change in diff(&old, &new, &tolerances)?.iter().filter(|c| c.beyond()) {
///     println!("{} {:?}: {:?}", change.id, change.status, change.measures);
/// }
/// # Ok::<(), hikage_bundle::BundleError>(())
/// ```
pub fn diff(old: &Bundle, new: &Bundle, tolerances: &Tolerances) -> Result<Vec<AssetDiff>, BundleError> {
    let (a, b) = (&old.manifest().assets, &new.manifest().assets);
    let mut ids: Vec<&str> = a.iter().chain(b).map(|x| x.id.as_str()).collect();
    ids.sort_unstable();
    ids.dedup();
    // By id, whatever order each manifest lists its assets in (one written by hand need not be
    // sorted; the first of a repeated id, as the readers take it).
    let (in_a, in_b) = (by_id(a), by_id(b));
    let work: Vec<(&str, Option<&Asset>, Option<&Asset>)> =
        ids.iter().map(|&id| (id, in_a.get(id).copied(), in_b.get(id).copied())).collect();
    // Assets on every core, each taken by the next free thread (their costs differ widely).
    let out = crate::parallel::map(&work, 2, |_, &(id, x, y)| compare(old, new, id, x, y, tolerances));
    let out: Vec<AssetDiff> = out.into_iter().collect::<Result<_, _>>()?;
    Ok(out)
}

/// `list`'s assets by id, the first of a repeated id (as the readers take it).
fn by_id(list: &[Asset]) -> std::collections::HashMap<&str, &Asset> {
    let mut map = std::collections::HashMap::with_capacity(list.len());
    for x in list {
        map.entry(x.id.as_str()).or_insert(x);
    }
    map
}

/// One asset's fate.
fn compare(
    old: &Bundle,
    new: &Bundle,
    id: &str,
    a: Option<&Asset>,
    b: Option<&Asset>,
    tol: &Tolerances,
) -> Result<AssetDiff, BundleError> {
    let entry = |kind, status, measures, note| AssetDiff { id: id.to_string(), kind, status, measures, note };
    let (a, b) = match (a, b) {
        (Some(a), Some(b)) => (a, b),
        (None, Some(b)) => return Ok(entry(b.kind, Status::Added, Vec::new(), None)),
        (Some(a), None) => return Ok(entry(a.kind, Status::Removed, Vec::new(), None)),
        (None, None) => unreachable!("an id comes from one of the manifests"),
    };
    if a.blake3 == b.blake3 && a.settings == b.settings {
        return Ok(entry(b.kind, Status::Same, Vec::new(), None));
    }
    if a.kind != b.kind {
        let note = format!("was a {:?}, now a {:?}", a.kind, b.kind);
        return Ok(entry(b.kind, Status::Changed, Vec::new(), Some(note)));
    }
    let measured = if b.kind.is_mesh() {
        let (ma, mb) = (old.read_mesh(id)?, new.read_mesh(id)?);
        mesh_change(b.kind, &ma, &mb, tol)
    } else {
        let (ta, tb) = (old.read_texture(id)?, new.read_texture(id)?);
        texture_change(a, b, &ta, &tb, tol)
    };
    Ok(match measured {
        Ok(measures) => {
            let changed = measures.iter().any(|m| m.limit.is_some() && m.value > 0.0);
            entry(b.kind, if changed { Status::Changed } else { Status::Same }, measures, None)
        }
        Err(note) => entry(b.kind, Status::Changed, Vec::new(), Some(note)),
    })
}

/// The largest of `values` and where it is.
fn largest(values: impl Iterator<Item = f64>) -> (f64, usize) {
    // A value that became NaN (or was compared with one) is no agreement: the largest change.
    let change = |v: f64| if v.is_nan() { f64::INFINITY } else { v };
    values.enumerate().fold((0.0, 0), |(m, at), (i, v)| if change(v) > m { (change(v), i) } else { (m, at) })
}

/// A texel's place in `[slice][row][col]` order, named with its slice's meaning (`slice`, e.g.
/// `direction`; none for 2D maps).
fn place(index: usize, w: usize, h: usize, slice: Option<&str>) -> String {
    let (x, y, z) = (index % w, (index / w) % h, index / (w * h));
    match slice {
        Some(name) => format!("texel ({x}, {y}), {name} {z}"),
        None => format!("texel ({x}, {y})"),
    }
}

/// The measures of a texture's change.
fn texture_change(
    a: &Asset,
    b: &Asset,
    ta: &TextureData,
    tb: &TextureData,
    tol: &Tolerances,
) -> Result<Vec<Measure>, String> {
    let (da, db) = (&ta.desc, &tb.desc);
    let size = |d: &crate::TextureDesc| (d.width, d.height, d.depth.max(1) * d.layers.max(1), d.format.channels());
    if size(da) != size(db) {
        return Err(format!("size changed from {:?} to {:?} (width, height, slices, channels)", size(da), size(db)));
    }
    let (w, h) = (db.width as usize, db.height as usize);
    let measure = |name: &str, value: f64, unit, limit: f32, at: Option<String>| Measure {
        name: name.to_string(),
        value,
        unit,
        limit: Some(limit as f64),
        at: (value > 0.0).then_some(at).flatten(),
    };
    Ok(match (&a.settings, &b.settings) {
        (Settings::Horizon(sa), Settings::Horizon(sb)) => {
            let (va, vb) = (ta.to_f32(0), tb.to_f32(0));
            let decode = |v: &[f32], s: &crate::HorizonSettings, f| -> Vec<(f32, f32)> {
                v.chunks_exact(2).map(|c| s.decode(f, c[0], c[1])).collect()
            };
            let (ha, hb) = (decode(&va, sa, da.format), decode(&vb, sb, db.format));
            let mut angles: Vec<f32> =
                ha.iter().zip(&hb).map(|(p, q)| (p.0.atan() - q.0.atan()).abs().to_degrees()).collect();
            let (max_angle, at_angle) = largest(angles.iter().map(|&x| x as f64));
            let texel = sb.texel_size.0.min(sb.texel_size.1).max(f32::MIN_POSITIVE);
            let (max_d, at_d) = largest(ha.iter().zip(&hb).map(|(p, q)| ((p.1 - q.1).abs() / texel) as f64));
            let slopes = SUN_ELEVATIONS.map(|e| e.to_radians().tan());
            let flips: usize =
                ha.iter().zip(&hb).map(|(p, q)| slopes.iter().filter(|&&t| (t > p.0) != (t > q.0)).count()).sum();
            let tests = ha.len() * slopes.len();
            let p99 = if angles.is_empty() {
                0.0
            } else {
                let k = (angles.len() - 1) * 99 / 100;
                *angles.select_nth_unstable_by(k, f32::total_cmp).1 as f64
            };
            let at = |i| Some(place(i, w, h, Some("direction")));
            vec![
                measure("horizon angle max", max_angle, "°", tol.horizon_degrees, at(at_angle)),
                Measure { name: "horizon angle p99".into(), value: p99, unit: "°", limit: None, at: None },
                measure("sun tests flipped", flips as f64 / tests.max(1) as f64, "", tol.sun_flips, None),
                measure("distance max", max_d, "texels", tol.distance_texels, at(at_d)),
            ]
        }
        (Settings::Heightfield(sa), Settings::Heightfield(sb)) => {
            let world = |t: &TextureData, s: &crate::HeightfieldSettings| -> Vec<f32> {
                t.channel_f32(0, 0).iter().map(|&v| s.world_height(v)).collect()
            };
            let (wa, wb) = (world(ta, sa), world(tb, sb));
            let (m, at) = largest(wa.iter().zip(&wb).map(|(p, q)| (p - q).abs() as f64));
            vec![measure("height max", m, "world units", tol.height, Some(place(at, w, h, None)))]
        }
        (Settings::AmbientOcclusion(_), Settings::AmbientOcclusion(_)) => {
            let (m, at) = values_change(ta, tb);
            vec![measure("occlusion max", m, "", tol.ao, Some(place(at, w, h, None)))]
        }
        (Settings::Relief(sa), Settings::Relief(sb)) => {
            let texels = |s: &crate::ReliefSettings| s.depth_scale as f64 * s.source_size.0 as f64;
            let (va, vb) = (ta.channel_f32(0, 0), tb.channel_f32(0, 0));
            let depth = |i: usize| (vb[i] as f64 * texels(sb), va[i] as f64 * texels(sa));
            let (deeper, at_deeper) = largest((0..va.len()).map(|i| depth(i).0 - depth(i).1));
            let (shallower, at_shallower) = largest((0..va.len()).map(|i| depth(i).1 - depth(i).0));
            let at = |i| Some(place(i, w, h, Some("layer")));
            vec![
                measure("relief deeper max", deeper, "texels", tol.relief_texels, at(at_deeper)),
                measure("relief shallower max", shallower, "texels", tol.relief_texels, at(at_shallower)),
            ]
        }
        _ => {
            let (m, at) = values_change(ta, tb);
            let slices = (db.depth.max(1) * db.layers.max(1) > 1).then_some("slice");
            vec![measure("value max", m, "", tol.value, Some(place(at / db.format.channels(), w, h, slices)))]
        }
    })
}

/// The largest change of any channel of any texel, and its index in `[texel][channel]` order.
fn values_change(ta: &TextureData, tb: &TextureData) -> (f64, usize) {
    let (va, vb) = (ta.to_f32(0), tb.to_f32(0));
    largest(va.iter().zip(&vb).map(|(p, q)| (p - q).abs() as f64))
}

/// The measures of a mesh's change: its counts, then every stream: positions as moves,
/// curvatures as relative changes, other float and normalised streams as values, integer
/// streams (strand indices, ids) and indices as elements that differ.
fn mesh_change(
    kind: AssetKind,
    ma: &crate::MeshData,
    mb: &crate::MeshData,
    tol: &Tolerances,
) -> Result<Vec<Measure>, String> {
    use crate::ComponentType;
    let (na, nb) = (ma.desc.vertex_count, mb.desc.vertex_count);
    let count =
        |name: &str, value: u64| Measure { name: name.into(), value: value as f64, unit: "", limit: None, at: None };
    let element = if kind == AssetKind::Strands { "point" } else { "vertex" };
    let held = |name: String, (value, at): (f64, usize), unit, limit: f32| Measure {
        name,
        value,
        unit,
        limit: Some(limit as f64),
        at: (value > 0.0).then(|| format!("{element} {at}")),
    };
    let mut out = Vec::new();
    if kind == AssetKind::Strands {
        let strands = |m: &crate::MeshData| -> u64 {
            m.desc.attribute("strand").map_or(0, |a| m.elements(a).filter(|e| e[0] == 0 && e[1] == 0).count() as u64)
        };
        out.push(count("strands", strands(mb)));
        out.push(count("points", nb as u64));
        if strands(ma) != strands(mb) {
            return Err(format!("{} strands, were {}", strands(mb), strands(ma)));
        }
    } else {
        out.push(count("vertices", nb as u64));
    }
    if na != nb {
        return Err(format!("{nb} vertices or points, were {na}"));
    }
    for b in &mb.desc.attributes {
        let Some(a) = ma.desc.attribute(&b.name).filter(|a| a.component == b.component && a.components == b.components)
        else {
            return Err(format!("stream `{}` is new or of a new type", b.name));
        };
        let per = b.components as usize;
        match (b.component, b.name.as_str()) {
            (ComponentType::F32, "position") => {
                let (pa, pb) =
                    (ma.read_f32("position").unwrap_or_default(), mb.read_f32("position").unwrap_or_default());
                let moves = pa
                    .chunks_exact(per)
                    .zip(pb.chunks_exact(per))
                    .map(|(p, q)| p.iter().zip(q).map(|(x, y)| (x - y) * (x - y)).sum::<f32>().sqrt() as f64);
                out.push(held("move max".into(), largest(moves), "world units", tol.point_move));
            }
            (ComponentType::F32, "curvature") => {
                let (ka, kb) =
                    (ma.read_f32("curvature").unwrap_or_default(), mb.read_f32("curvature").unwrap_or_default());
                let (m, at) =
                    largest(ka.iter().zip(&kb).map(|(p, q)| ((p - q).abs() / p.abs().max(q.abs()).max(1e-6)) as f64));
                out.push(held("curvature relative max".into(), (m, at / per), "", tol.curvature));
            }
            (c, name) if c != ComponentType::U32 && !matches!(name, "strand") => {
                let decode = |e: &[u8], k: usize| -> f64 { c.normalized(e, k) as f64 };
                let changes = ma
                    .elements(a)
                    .zip(mb.elements(b))
                    .map(|(p, q)| (0..per).map(|k| (decode(p, k) - decode(q, k)).abs()).fold(0.0, f64::max));
                out.push(held(format!("`{name}` max"), largest(changes), "", tol.value));
            }
            (_, name) => {
                let differ: Vec<usize> = ma
                    .elements(a)
                    .zip(mb.elements(b))
                    .enumerate()
                    .filter(|(_, (p, q))| p != q)
                    .map(|(i, _)| i)
                    .collect();
                out.push(Measure {
                    name: format!("`{name}` elements that differ"),
                    value: differ.len() as f64,
                    unit: "",
                    limit: Some(0.0),
                    at: differ.first().map(|i| format!("{element} {i}")),
                });
            }
        }
    }
    if ma.read_indices() != mb.read_indices() {
        let (ia, ib) = (ma.read_indices().unwrap_or_default(), mb.read_indices().unwrap_or_default());
        if ia.len() != ib.len() {
            return Err(format!("{} indices, were {}", ib.len(), ia.len()));
        }
        let differ = ia.iter().zip(&ib).filter(|(p, q)| p != q).count();
        out.push(Measure {
            name: "indices that differ".into(),
            value: differ as f64,
            unit: "",
            limit: Some(0.0),
            at: None,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {

    /// Each tolerance's name is the key a pipeline writes and the field it sets, and its flag
    /// is the name with dashes: the one table is what every spelling reads.
    #[test]
    fn each_tolerance_is_one_name_one_flag_one_field() {
        for (k, t) in TOLERANCES.iter().enumerate() {
            let parsed: Tolerances = ron::from_str(&format!("({}: {})", t.name, k + 1)).unwrap();
            let mut values = parsed;
            assert_eq!(*(t.field)(&mut values), (k + 1) as f32, "{}", t.name);
            assert_eq!(parsed.named()[k], (t.name, (k + 1) as f32));
            assert_eq!(t.flag, t.name.replace('_', "-"));
            assert!(!t.doc.ends_with('.') && !t.unit.is_empty(), "a help line, as clap prints them");
        }
        let names: std::collections::BTreeSet<&str> = TOLERANCES.iter().map(|t| t.name).collect();
        assert_eq!(names.len(), TOLERANCES.len());
    }

    use super::*;

    /// A value that became NaN is the largest change, not none; a NaN or negative tolerance is
    /// named.
    #[test]
    fn nan_is_the_largest_change_and_bad_tolerances_are_named() {
        assert_eq!(largest([0.5, f64::NAN, 2.0].into_iter()), (f64::INFINITY, 1));
        assert_eq!(largest([0.5, 2.0, 1.0].into_iter()), (2.0, 1));
        assert!(Tolerances::default().check().is_ok());
        let nan = Tolerances { ao: f32::NAN, ..Tolerances::default() };
        assert!(nan.check().unwrap_err().starts_with("ao must be a finite number"));
        let negative = Tolerances { point_move: -1.0, ..Tolerances::default() };
        assert!(negative.check().unwrap_err().starts_with("point_move"));
    }
}
