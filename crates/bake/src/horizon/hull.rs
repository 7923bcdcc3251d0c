//! Upper convex hulls of line samples, for horizon queries from a point to their left.
//!
//! The horizon of a point seen along a line is a tangent to the upper convex hull of the
//! samples ahead of it (Dozier 1981; Timonen & Westerholm 2010): samples under the hull can never
//! be a horizon for any point behind them. Both hulls here answer "the sample of greatest slope
//! from origin `o`", with `o` left of every sample (smaller `x`): slopes along an upper hull in
//! `x` order rise to the tangent vertex and fall after it, so the search walks from the previous
//! answer, which for neighbouring origins is almost always within a step or two.

/// A sample on a line: `x` in canonical columns, `h` in world height units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Pt {
    pub x: f32,
    pub h: f32,
}

/// The best hull vertex seen from an origin: its slope numerator and run (`h - o.h`,
/// `x - o.x`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Hit {
    pub rise: f32,
    pub run: f32,
}

impl Hit {
    /// True when `self` has a strictly greater slope than `other` (runs are positive).
    #[inline]
    pub fn steeper_than(&self, other: &Hit) -> bool {
        self.rise * other.run > other.rise * self.run
    }
}

#[inline]
fn hit(o: Pt, p: Pt) -> Hit {
    Hit { rise: p.h - o.h, run: p.x - o.x }
}

/// Walks a hull stored in `x` order (increasing or decreasing) from `hint` to the vertex of
/// greatest slope from `o`.
#[inline]
fn walk(pts: &[Pt], o: Pt, hint: &mut usize) -> Option<Hit> {
    if pts.is_empty() {
        return None;
    }
    let mut i = (*hint).min(pts.len() - 1);
    let mut best = hit(o, pts[i]);
    while i + 1 < pts.len() {
        let next = hit(o, pts[i + 1]);
        if !next.steeper_than(&best) {
            break;
        }
        best = next;
        i += 1;
    }
    while i > 0 {
        let prev = hit(o, pts[i - 1]);
        if !prev.steeper_than(&best) {
            break;
        }
        best = prev;
        i -= 1;
    }
    *hint = i;
    Some(best)
}

/// True when `mid` lies on or below the segment `left`–`right` (`left.x < mid.x < right.x`).
#[inline]
fn not_above(left: Pt, mid: Pt, right: Pt) -> bool {
    (mid.h - left.h) * (right.x - left.x) <= (right.h - left.h) * (mid.x - left.x)
}

/// Upper hull of samples inserted right to left (each new sample has the smallest `x`).
/// Stored with the farthest sample first, so `pts` is in decreasing `x` order.
#[derive(Default)]
pub(crate) struct SuffixHull {
    pts: Vec<Pt>,
}

impl SuffixHull {
    pub fn clear(&mut self) {
        self.pts.clear();
    }

    /// Adds a sample left of all others.
    #[inline]
    pub fn push_front(&mut self, p: Pt) {
        while self.pts.len() >= 2 {
            let a = self.pts[self.pts.len() - 1];
            let b = self.pts[self.pts.len() - 2];
            if not_above(p, a, b) {
                self.pts.pop();
            } else {
                break;
            }
        }
        self.pts.push(p);
    }

    /// The vertex of greatest slope from `o`, walking from `hint` (updated).
    #[inline]
    pub fn tangent(&self, o: Pt, hint: &mut usize) -> Option<Hit> {
        // Slopes are unimodal along the hull in either order, and stack indices of surviving
        // vertices do not move when samples are pushed, so the hint stays meaningful.
        walk(&self.pts, o, hint)
    }
}

/// Upper hull of samples inserted left to right, with an undo log so the most recent
/// insertions can be taken back in reverse order (a prefix that shrinks one sample at a time).
///
/// An insertion never destroys the vertices it removes: it shortens the live stack and
/// overwrites one slot, so taking it back restores that slot and the old length in `O(1)`,
/// however many vertices it had removed.
#[derive(Default)]
pub(crate) struct PrefixHull {
    /// The live hull is `pts[..len]`; slots beyond it hold vertices an insertion hid.
    pts: Vec<Pt>,
    len: usize,
    /// Per insertion: the length before it and the vertex its sample overwrote.
    log: Vec<(u32, Pt)>,
}

/// Log entry of a sample outside the map (nothing inserted).
const SKIPPED: u32 = u32::MAX;

impl PrefixHull {
    pub fn clear(&mut self) {
        self.pts.clear();
        self.len = 0;
        self.log.clear();
    }

    /// Adds a sample right of all others (`None`: a sample outside the map, logged so that
    /// [`undo`](Self::undo) stays in step).
    #[inline]
    pub fn push_back(&mut self, q: Option<Pt>) {
        let Some(q) = q else {
            self.log.push((SKIPPED, Pt { x: 0.0, h: 0.0 }));
            return;
        };
        let mut n = self.len;
        while n >= 2 && not_above(self.pts[n - 2], self.pts[n - 1], q) {
            n -= 1;
        }
        let saved = if n < self.pts.len() {
            std::mem::replace(&mut self.pts[n], q)
        } else {
            self.pts.push(q);
            q
        };
        self.log.push((self.len as u32, saved));
        self.len = n + 1;
    }

    /// Takes back the most recent insertion.
    #[inline]
    pub fn undo(&mut self) {
        match self.log.pop() {
            None | Some((SKIPPED, _)) => {}
            Some((len, saved)) => {
                self.pts[self.len - 1] = saved;
                self.len = len as usize;
            }
        }
    }

    /// The vertex of greatest slope from `o`, walking from `hint` (updated).
    #[inline]
    pub fn tangent(&self, o: Pt, hint: &mut usize) -> Option<Hit> {
        walk(&self.pts[..self.len], o, hint)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(points: &[Pt], o: Pt) -> f32 {
        points.iter().map(|p| (p.h - o.h) / (p.x - o.x)).fold(f32::NEG_INFINITY, f32::max)
    }

    fn pseudo(i: u32) -> f32 {
        ((i.wrapping_mul(2654435761) >> 8) % 1000) as f32 / 100.0
    }

    #[test]
    fn both_hulls_find_the_steepest_sample() {
        let pts: Vec<Pt> =
            (0..200).map(|i| Pt { x: i as f32 + 10.0, h: pseudo(i) + (i as f32 * 0.05).sin() }).collect();
        // Suffix: insert right to left, query from origins further left.
        let mut s = SuffixHull::default();
        for (n, p) in pts.iter().enumerate().rev() {
            s.push_front(*p);
            for oh in [-5.0f32, 0.0, 3.0, 12.0] {
                let o = Pt { x: p.x - 1.5, h: oh };
                let h = s.tangent(o, &mut 0).unwrap();
                let want = brute(&pts[n..], o);
                assert!((h.rise / h.run - want).abs() < 1e-5, "suffix at {n}: {} vs {want}", h.rise / h.run);
            }
        }
        // Prefix: insert left to right, then undo one at a time.
        let mut p = PrefixHull::default();
        for q in &pts {
            p.push_back(Some(*q));
            p.push_back(None);
        }
        for len in (1..=pts.len()).rev() {
            for oh in [-5.0f32, 4.0, 20.0] {
                let o = Pt { x: 3.0, h: oh };
                let h = p.tangent(o, &mut 0).unwrap();
                let want = brute(&pts[..len], o);
                assert!((h.rise / h.run - want).abs() < 1e-5, "prefix of {len}");
            }
            p.undo();
            p.undo();
        }
        assert!(p.tangent(Pt { x: 0.0, h: 0.0 }, &mut 0).is_none());
    }

    #[test]
    fn prefix_undo_restores_the_hull_under_any_interleaving() {
        // Pushes and undos in a pseudo-random order; after each step the hull must answer as
        // the brute force over the samples currently inserted.
        let mut hull = PrefixHull::default();
        let mut live: Vec<Option<Pt>> = Vec::new();
        let mut x = 10.0f32;
        for step in 0..3000u32 {
            let r = step.wrapping_mul(2246822519).rotate_left(7) % 10;
            if r < 4 && !live.is_empty() {
                hull.undo();
                live.pop();
            } else {
                let q = (r != 9).then(|| Pt { x, h: pseudo(step) * 3.0 + (x * 0.1).sin() * 5.0 });
                x += 1.0;
                hull.push_back(q);
                live.push(q);
                if r == 8 {
                    // The next undo takes this sample back; its x is reused by the next push.
                    hull.undo();
                    live.pop();
                    x -= 1.0;
                }
            }
            let pts: Vec<Pt> = live.iter().flatten().copied().collect();
            for oh in [-10.0f32, 2.0, 30.0] {
                let o = Pt { x: 0.0, h: oh };
                match hull.tangent(o, &mut 0) {
                    Some(h) => assert!((h.rise / h.run - brute(&pts, o)).abs() < 1e-5, "step {step}"),
                    None => assert!(pts.is_empty(), "step {step}: hull empty, {} samples live", pts.len()),
                }
            }
        }
    }
}
