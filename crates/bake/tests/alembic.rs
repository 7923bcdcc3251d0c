//! Alembic grooms: Blender 5.0's export of the groom in `data/grooms/` (written by
//! `data/grooms/make_grooms.py`) reads as the `.hair` file's strands; Unreal's per-strand groom
//! attributes, which Blender does not write, are read from an archive laid out by
//! hikage-devkit; and every mistake in an archive (the export edited at the place that holds the
//! mistake) is an error naming the file and the object, never a panic.

use std::path::{Path, PathBuf};

use hikage_bake::jobs::StrandsJob;
use hikage_bake::strands::Strands;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/grooms").join(name)
}

fn load(path: &Path) -> Result<Strands, String> {
    StrandsJob::new("groom", path.to_path_buf()).load(path).map_err(|e| e.to_string())
}

/// `bytes` written to a scratch file called `name`.
fn scratch(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("alembic");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// Where `pattern` first occurs in `bytes`.
fn find(bytes: &[u8], pattern: &[u8]) -> usize {
    bytes.windows(pattern.len()).position(|w| w == pattern).expect("the pattern is in the export")
}

fn le(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

#[test]
fn blenders_alembic_groom_reads_as_the_hair_file() {
    let hair = load(&data("groom.hair")).unwrap();
    let abc = load(&data("groom_blender.abc")).unwrap();
    assert_eq!(abc.segments, hair.segments);
    assert_eq!(abc.points, hair.points);
    assert_eq!(abc.thickness, hair.thickness);
    assert_eq!(abc.default_thickness, hair.default_thickness);
}

#[test]
fn mistakes_are_named_with_the_file_and_the_object() {
    let bytes = std::fs::read(data("groom_blender.abc")).unwrap();
    let hair = load(&data("groom.hair")).unwrap();
    let object = "object /groom/groom";
    // The first point, as the export holds it (Y up, metres), and the first width.
    let point = find(&bytes, &le(&hair.points[0]));
    let width = find(&bytes, &le(&[hair.thickness.as_ref().unwrap()[0]]));
    // The 48 vertex counts of 8.
    let counts = find(&bytes, &[8, 0, 0, 0].repeat(48));
    let edit = |at: usize, new: &[u8]| {
        let mut b = bytes.clone();
        b[at..at + new.len()].copy_from_slice(new);
        b
    };
    let count_pair = |a: i32, b: i32| [a.to_le_bytes(), b.to_le_bytes()].concat();
    for (name, case, want) in [
        ("nan.abc", edit(point, &le(&[f32::NAN])), "point 0 is (NaN"),
        ("negative.abc", edit(width, &le(&[-0.5])), "width[0] is -0.5"),
        ("counts.abc", edit(counts, &count_pair(9, 8)), "add up to 385 points, but the points hold 384"),
        ("one_point.abc", edit(counts, &count_pair(1, 15)), "curve 0 has 1 points"),
        ("truncated.abc", bytes[..bytes.len() / 2].to_vec(), "past the end"),
        ("unfinished.abc", edit(5, &[0]), "not finished"),
    ] {
        let e = load(&scratch(name, &case)).unwrap_err();
        assert!(e.contains(name) && e.contains(want), "{name}: {e}");
        if !matches!(name, "truncated.abc" | "unfinished.abc") {
            assert!(e.contains(object), "{name}: {e}");
        }
    }
    // No curves: the same archive with its curves object's schema renamed to points.
    let mut points = bytes.clone();
    while let Some(at) = points.windows(13).position(|w| w == b"AbcGeom_Curve") {
        points[at..at + 13].copy_from_slice(b"AbcGeom_Point");
    }
    let e = load(&scratch("points.abc", &points)).unwrap_err();
    assert!(e.contains("points.abc") && e.contains("no curves"), "{e}");
}

/// An Ogawa group's children (offsets, data flag in the high bit), at `offset`.
fn children(bytes: &[u8], offset: usize) -> Vec<u64> {
    let word = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap());
    (0..word(offset) as usize).map(|i| word(offset + 8 + 8 * i)).collect()
}

#[test]
fn a_cyclic_archive_is_an_error() {
    let mut bytes = std::fs::read(data("groom_blender.abc")).unwrap();
    // The top object is the root group's third child; its first child object (group slot 1)
    // is made the top object itself.
    let root = u64::from_le_bytes(bytes[8..16].try_into().unwrap()) as usize;
    let top = children(&bytes, root)[2];
    let slot = top as usize + 8 + 8;
    bytes[slot..slot + 8].copy_from_slice(&top.to_le_bytes());
    let e = load(&scratch("cyclic.abc", &bytes)).unwrap_err();
    assert!(e.contains("cyclic.abc") && e.contains("cyclic"), "{e}");
}

#[test]
fn damaged_archives_are_errors_not_panics() {
    let bytes = std::fs::read(data("groom_guides_blender.abc")).unwrap();
    let mut errors = 0;
    // Cut short at every 7th length, then 400 stretches of 8 bytes overwritten with a
    // pseudo-random pattern: each reads as a groom or is an error naming the file.
    let mut cases: Vec<Vec<u8>> = (0..bytes.len()).step_by(7).map(|n| bytes[..n].to_vec()).collect();
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    for _ in 0..400 {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        let at = (seed % (bytes.len() as u64 - 8)) as usize;
        let mut b = bytes.clone();
        b[at..at + 8].copy_from_slice(&(seed.rotate_left(29)).to_le_bytes());
        cases.push(b);
    }
    let path = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("alembic").join("damaged.abc");
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    for case in &cases {
        std::fs::write(&path, case).unwrap();
        if let Err(e) = load(&path) {
            assert!(e.contains("damaged.abc"), "{e}");
            errors += 1;
        }
    }
    // Every truncation is an error; the overwrites land in bytes that matter often enough.
    assert!(errors >= bytes.len() / 7, "{errors} errors in {} cases", cases.len());
}

/// Unreal's groom attributes per strand in `.arbGeomParams`, as Houdini's and Ornatrix's
/// exports hold them (Blender's exporter drops curve attributes, and no Alembic library is
/// packaged here, so hikage-devkit's writer lays the archive out): `groom_width` indexed, one a
/// strand, before the plain `width`; per-point `groom_color`; `groom_guide` and
/// `groom_group_id` per strand; under an `Xform` that moves the groom 1 up.
#[test]
fn unreals_groom_attributes_per_strand() {
    use hikage_devkit::alembic::{Object, Prop, archive, curves};
    let points: Vec<[f32; 3]> = (0..9).map(|i| [(i / 3) as f32, (i % 3) as f32 * 0.1, 0.0]).collect();
    let colors: Vec<f32> = (0..9).flat_map(|i| [i as f32 / 9.0, 0.5, 0.25]).collect();
    let param = |scope: &str| format!("geoScope={scope};isGeomParam=true");
    let arb = Prop::compound(
        ".arbGeomParams",
        "",
        vec![
            Prop::compound(
                "groom_width",
                &param("uni"),
                vec![Prop::floats(".vals", 1, "", &[0.001, 0.002]), Prop::ints(".indices", "", &[1, 0, 0])],
            ),
            Prop::floats("groom_color", 3, &param("vtx"), &colors),
            Prop::ints("groom_guide", &param("uni"), &[0, 1, 0]),
            Prop::ints("groom_group_id", &param("uni"), &[4, 4, 5]),
        ],
    );
    let width = Prop::floats("width", 1, &param("vtx"), &[0.5; 9]);
    let groom = curves("hair", &points, &[3, 3, 3], vec![width, arb]);
    let character = Object {
        name: "character".into(),
        meta: "schema=AbcGeom_Xform_v3".into(),
        props: vec![Prop::translate([0.0, 1.0, 0.0])],
        children: vec![groom],
    };
    let path = scratch("unreal.abc", &archive(&[character]));

    let s = load(&path).unwrap();
    // The guide (strand 1) is left out; the others are moved 1 up.
    assert_eq!(s.segments, [2, 2]);
    let want: Vec<[f32; 3]> = [0, 1, 2, 6, 7, 8].iter().map(|&i| [points[i][0], points[i][1] + 1.0, 0.0]).collect();
    assert_eq!(s.points, want);
    // groom_width, not width: strand 0 takes value 1, strand 2 value 0.
    assert_eq!(s.thickness.as_deref(), Some(&[0.002, 0.002, 0.002, 0.001, 0.001, 0.001][..]));
    let want_colors: Vec<[f32; 3]> = [0, 1, 2, 6, 7, 8].iter().map(|&i| [i as f32 / 9.0, 0.5, 0.25]).collect();
    assert_eq!(s.color.as_deref(), Some(&want_colors[..]));
    // One group alone.
    let mut job = StrandsJob::new("groom", path.clone());
    job.options.group = Some(5);
    assert_eq!(job.load(&path).unwrap().points, want[3..]);
    job.options.group = Some(4);
    assert_eq!(job.load(&path).unwrap().points, want[..3]);

    // A guide flag for each of two strands where there are three is named.
    let short = Prop::compound(".arbGeomParams", "", vec![Prop::ints("groom_guide", &param("uni"), &[0, 1])]);
    let path = scratch("short_guides.abc", &archive(&[curves("hair", &points, &[3, 3, 3], vec![short])]));
    let e = load(&path).unwrap_err();
    assert!(
        e.contains("short_guides.abc") && e.contains("object /hair") && e.contains("groom_guide holds 2 values"),
        "{e}"
    );
}
