//! Curves as interchange files hold them (USD prims, Alembic objects): each set in the file's
//! world frame with its per-point and per-strand values, and the one rule that gathers the sets
//! into [`Strands`] for both readers.
//!
//! - Control points are taken as points, whatever the basis: a pinned Catmull-Rom curve
//!   (Blender, Houdini) passes through them, and hair strips are polylines of their own.
//!   Unreal's groom importer does the same.
//! - Guides (Unreal's `groom_guide`) shape a groom in its tool and are not rendered: they are
//!   left out. A job may keep one group (`groom_group_id`; strands without one are group 0).
//! - Widths are kept when every set has them, colours likewise; the widest point is the
//!   default thickness that the job's widths stand for.

use super::Strands;
use super::cyhair::HairLimits;

/// One prim's or object's curves, in the file's world frame.
#[derive(Debug, Default)]
pub(crate) struct CurveSet {
    /// Points per curve (each 2 to 65536).
    pub counts: Vec<usize>,
    /// Every curve's points, curve after curve.
    pub points: Vec<[f32; 3]>,
    /// Diameter at each point, in the file's world units.
    pub widths: Option<Vec<f32>>,
    /// Linear RGB at each point.
    pub colors: Option<Vec<[f32; 3]>>,
    /// Whether each curve is a guide (left out of the strips).
    pub guides: Option<Vec<bool>>,
    /// Each curve's group id.
    pub groups: Option<Vec<i32>>,
}

/// Where in a file a value was wrong (`None`: the file as a whole), and what was expected.
pub(crate) type Problem = (Option<String>, String);

/// The strands of `sets`: guides left out, and only `group`'s curves when one is named.
pub(crate) fn gather(sets: Vec<CurveSet>, group: Option<i32>, limits: &HairLimits) -> Result<Strands, Problem> {
    if sets.is_empty() {
        return Err((None, "no curves: expected a groom exported as curves".into()));
    }
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
    let (mut guides, mut groups_seen) = (0usize, Vec::new());
    for set in sets {
        let mut keep = Vec::with_capacity(set.counts.len());
        for curve in 0..set.counts.len() {
            if set.guides.as_ref().is_some_and(|g| g[curve]) {
                guides += 1;
                keep.push(false);
                continue;
            }
            let id = set.groups.as_ref().map_or(0, |g| g[curve]);
            if !groups_seen.contains(&id) {
                groups_seen.push(id);
            }
            keep.push(group.is_none_or(|want| want == id));
        }
        if out.segments.is_empty() && !keep.is_empty() && keep.iter().all(|&k| k) {
            // The first set, whole: its arrays become the strands', not copied.
            out.segments = set.counts.iter().map(|&n| (n - 1) as u16).collect();
            (out.points, out.thickness, out.color) = (set.points, set.widths, set.colors);
            continue;
        }
        let mut start = 0;
        for (curve, &n) in set.counts.iter().enumerate() {
            let range = start..start + n;
            start += n;
            if !keep[curve] {
                continue;
            }
            out.segments.push((n - 1) as u16);
            out.points.extend_from_slice(&set.points[range.clone()]);
            match (&set.widths, &mut out.thickness) {
                (Some(w), Some(t)) => t.extend_from_slice(&w[range.clone()]),
                _ => out.thickness = None,
            }
            match (&set.colors, &mut out.color) {
                (Some(c), Some(o)) => o.extend_from_slice(&c[range]),
                _ => out.color = None,
            }
        }
    }
    if out.segments.is_empty() {
        groups_seen.sort_unstable();
        return Err((
            None,
            match group {
                Some(g) if !groups_seen.is_empty() => {
                    format!("no strand in group {g}: the file's groups are {groups_seen:?}")
                }
                _ if guides > 0 => {
                    format!("only guides ({guides} curves marked groom_guide): expected rendered strands")
                }
                _ => "no curves: expected a groom exported as curves".into(),
            },
        ));
    }
    if out.segments.len() as u64 > limits.max_strands {
        return Err((None, format!("{} strands, above the limit of {}", out.segments.len(), limits.max_strands)));
    }
    out.default_thickness = out.thickness.iter().flatten().fold(0.0, |m: f32, &w| m.max(w));
    Ok(out)
}

/// Checks curve point counts against the points they share out and the limits, before any
/// per-point value is read: `before` points are already taken by earlier sets.
pub(crate) fn check_counts(
    counts: &[i64],
    points: u64,
    before: u64,
    limits: &HairLimits,
) -> Result<Vec<usize>, String> {
    let total: u64 = counts.iter().map(|&c| c.max(0) as u64).sum();
    if before + total > limits.max_points {
        return Err(format!("{} points in all, above the limit of {}", before + total, limits.max_points));
    }
    if total != points {
        return Err(format!("the curves' vertex counts add up to {total} points, but the points hold {points}"));
    }
    if let Some((i, &c)) = counts.iter().enumerate().find(|(_, c)| !(2..=65536).contains(*c)) {
        return Err(format!("curve {i} has {c} points: expected 2 to 65536"));
    }
    Ok(counts.iter().map(|&c| c as usize).collect())
}

/// How a value is shared out over curves, in USD's words (Alembic's scopes map onto them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Interpolation {
    /// One value for every point.
    Constant,
    /// One value a curve.
    Uniform,
    /// One value a segment end; with control points taken as points, one a point.
    Varying,
    /// One value a point.
    Vertex,
}

impl Interpolation {
    /// USD's name for it.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Interpolation::Constant => "constant",
            Interpolation::Uniform => "uniform",
            Interpolation::Varying => "varying",
            Interpolation::Vertex => "vertex",
        }
    }

    /// The interpolation a value of `len` entries has over curves of `counts` points when the
    /// file does not say: one value, one a curve or one a point.
    pub(crate) fn by_count(len: usize, counts: &[usize]) -> Option<Interpolation> {
        let points: usize = counts.iter().sum();
        match len {
            1 => Some(Interpolation::Constant),
            n if n == counts.len() => Some(Interpolation::Uniform),
            n if n == points => Some(Interpolation::Vertex),
            _ => None,
        }
    }
}

/// Values given at `interpolation`, one per point of curves of `counts` points.
pub(crate) fn spread<T: Copy>(
    values: &[T],
    interpolation: Interpolation,
    counts: &[usize],
    name: &str,
) -> Result<Vec<T>, String> {
    let points: usize = counts.iter().sum();
    let wrong = |want: usize| {
        format!("{name} holds {} values for {} interpolation, expected {want}", values.len(), interpolation.name())
    };
    match interpolation {
        Interpolation::Constant => match values {
            [v] => Ok(vec![*v; points]),
            _ => Err(wrong(1)),
        },
        Interpolation::Uniform if values.len() == counts.len() => {
            Ok(counts.iter().zip(values).flat_map(|(&n, v)| std::iter::repeat_n(*v, n)).collect())
        }
        Interpolation::Uniform => Err(wrong(counts.len())),
        Interpolation::Vertex | Interpolation::Varying if values.len() == points => Ok(values.to_vec()),
        Interpolation::Vertex | Interpolation::Varying => Err(wrong(points)),
    }
}

/// Values given once or once a curve (a per-strand flag or id), one per curve.
pub(crate) fn per_curve<T: Copy>(values: &[T], counts: &[usize], name: &str) -> Result<Vec<T>, String> {
    match values {
        [v] => Ok(vec![*v; counts.len()]),
        v if v.len() == counts.len() => Ok(v.to_vec()),
        v => Err(format!("{name} holds {} values: expected 1 or one a curve ({})", v.len(), counts.len())),
    }
}

/// Checks that every width is a finite diameter of 0 or more.
pub(crate) fn check_widths(widths: &[f32], name: &str) -> Result<(), String> {
    match widths.iter().enumerate().find(|(_, v)| !(v.is_finite() && **v >= 0.0)) {
        Some((i, v)) => Err(format!("{name}[{i}] is {v}: expected a finite width of 0 or more")),
        None => Ok(()),
    }
}

/// Checks that every colour component is finite.
pub(crate) fn check_colors(colors: &[[f32; 3]], name: &str) -> Result<(), String> {
    match colors.iter().enumerate().find(|(_, v)| !v.iter().all(|c| c.is_finite())) {
        Some((i, v)) => Err(format!("{name}[{i}] is {v:?}: expected finite components")),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(counts: &[usize], guides: Option<Vec<bool>>, groups: Option<Vec<i32>>) -> CurveSet {
        let n: usize = counts.iter().sum();
        CurveSet {
            counts: counts.to_vec(),
            points: (0..n).map(|i| [i as f32, 0.0, 0.0]).collect(),
            widths: Some((0..n).map(|i| i as f32).collect()),
            colors: None,
            guides,
            groups,
        }
    }

    #[test]
    fn guides_are_left_out_and_a_group_is_kept_alone() {
        let sets = || vec![set(&[2, 3, 2], Some(vec![false, true, false]), Some(vec![1, 1, 2]))];
        let all = gather(sets(), None, &HairLimits::default()).unwrap();
        assert_eq!(all.segments, [1, 1]);
        assert_eq!(all.points.iter().map(|p| p[0]).collect::<Vec<_>>(), [0.0, 1.0, 5.0, 6.0]);
        assert_eq!(all.thickness.as_deref(), Some(&[0.0, 1.0, 5.0, 6.0][..]));
        assert_eq!(all.default_thickness, 6.0);
        assert_eq!(all.color, None);
        let two = gather(sets(), Some(2), &HairLimits::default()).unwrap();
        assert_eq!(two.points.iter().map(|p| p[0]).collect::<Vec<_>>(), [5.0, 6.0]);
        let none = gather(sets(), Some(7), &HairLimits::default()).unwrap_err();
        assert!(none.1.contains("no strand in group 7") && none.1.contains("[1, 2]"), "{none:?}");
        let guides = vec![set(&[2], Some(vec![true]), None)];
        assert!(gather(guides, None, &HairLimits::default()).unwrap_err().1.contains("only guides"));
    }

    #[test]
    fn values_spread_over_points_by_interpolation() {
        let counts = [2, 3];
        assert_eq!(spread(&[7], Interpolation::Constant, &counts, "w").unwrap(), [7; 5]);
        assert_eq!(spread(&[1, 2], Interpolation::Uniform, &counts, "w").unwrap(), [1, 1, 2, 2, 2]);
        assert!(spread(&[1, 2, 3], Interpolation::Vertex, &counts, "w").is_err());
        assert_eq!(Interpolation::by_count(2, &counts), Some(Interpolation::Uniform));
        assert_eq!(Interpolation::by_count(5, &counts), Some(Interpolation::Vertex));
        assert_eq!(Interpolation::by_count(3, &counts), None);
        assert!(check_counts(&[2, 1], 3, 0, &HairLimits::default()).unwrap_err().contains("curve 1 has 1 points"));
        assert!(check_counts(&[2, 2], 3, 0, &HairLimits::default()).unwrap_err().contains("add up to 4"));
    }
}
