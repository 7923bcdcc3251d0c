//! Strands from Wavefront OBJ polylines: `v x y z` positions and `l i j k …` elements (two or
//! more 1-based indices, negative ones counting back from the last position). Each `l` is one
//! strand; other statements are ignored. Widths and opacities come from the job's defaults.

use super::Strands;

/// Parses OBJ text into strands. Errors name the line and what was expected.
pub fn parse(text: &str, max_points: u64) -> Result<Strands, (String, String)> {
    let mut positions: Vec<[f32; 3]> = Vec::new();
    let mut strands = Strands {
        segments: Vec::new(),
        points: Vec::new(),
        thickness: None,
        transparency: None,
        color: None,
        default_thickness: 1.0,
        default_transparency: 0.0,
        default_color: [1.0, 1.0, 1.0],
    };
    for (n, line) in text.lines().enumerate() {
        let place = || format!("line {}", n + 1);
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let mut p = [0.0f32; 3];
                for c in &mut p {
                    let w = words.next().ok_or_else(|| (place(), "expected `v x y z`".to_string()))?;
                    *c = w.parse().map_err(|_| (place(), format!("expected a number, found {w:?}")))?;
                    if !c.is_finite() {
                        return Err((place(), format!("expected a finite coordinate, found {w}")));
                    }
                }
                positions.push(p);
            }
            Some("l") => {
                let mut count = 0u32;
                for w in words {
                    // `l` may carry `v/vt` pairs; the position index comes first.
                    let first = w.split('/').next().unwrap_or(w);
                    let i: i64 = first.parse().map_err(|_| (place(), format!("expected an index, found {w:?}")))?;
                    let len = positions.len() as i64;
                    let k = if i > 0 { i - 1 } else { len + i };
                    if i == 0 || !(0..len).contains(&k) {
                        return Err((place(), format!("index {i} is out of range: {len} positions so far")));
                    }
                    if strands.points.len() as u64 >= max_points {
                        return Err((place(), format!("more than the limit of {max_points} strand points")));
                    }
                    strands.points.push(positions[k as usize]);
                    count += 1;
                }
                if count < 2 {
                    return Err((place(), format!("a polyline needs two or more indices, found {count}")));
                }
                if count - 1 > u16::MAX as u32 {
                    return Err((place(), format!("a strand may have at most 65535 segments, found {}", count - 1)));
                }
                strands.segments.push((count - 1) as u16);
            }
            _ => {}
        }
    }
    if strands.segments.is_empty() {
        return Err(("end of file".into(), "expected at least one `l` polyline".into()));
    }
    Ok(strands)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polylines_become_strands() {
        let s = parse("v 0 0 0\nv 0 1 0\nv 0 2 0\nv 1 0 0\nl 1 2 3\nl -1 1\n# comment\nf 1 2 3\n", 100).unwrap();
        assert_eq!(s.segments, vec![2, 1]);
        assert_eq!(s.points, vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 2.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]);
    }

    #[test]
    fn bad_polylines_name_their_line() {
        for (text, line, needle) in [
            ("v 0 0 0\nl 1\n", "line 2", "two or more"),
            ("v 0 0 0\nv 1 1 1\nl 1 3\n", "line 3", "out of range"),
            ("v 0 nan 0\n", "line 1", "finite"),
            ("v 0 0\n", "line 1", "v x y z"),
            ("v 0 0 0\n", "end of file", "at least one"),
            ("v 0 0 0\nl 1 x\n", "line 2", "index"),
        ] {
            let (place, message) = parse(text, 100).unwrap_err();
            assert_eq!(place, line, "{text:?}");
            assert!(message.contains(needle), "{message}");
        }
        assert!(parse("v 0 0 0\nl 1 1 1 1\n", 3).unwrap_err().1.contains("limit"));
    }
}
