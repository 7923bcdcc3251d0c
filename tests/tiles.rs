//! Tiled horizon jobs end to end: `hikage bake` of a pipeline holding one map baked whole and in
//! tiles, every tile's heights, horizons and occlusion against the same region of the whole
//! map's, their placements, and tiles spread over shards and merged.

use hikage_bundle::{Bundle, Settings, TextureData};

use crate::util::{Dir, stderr};

const W: u32 = 150;
const H: u32 = 110;

/// A rough 150×110 raw float map (not square, so `raw_size` is needed).
fn map_bytes() -> Vec<u8> {
    (0..H)
        .flat_map(|y| {
            (0..W).map(move |x| {
                let (x, y) = (x as f32, y as f32);
                (x * 0.21).sin() * 9.0
                    + (y * 0.33 + x * 0.05).cos() * 7.0
                    + hikage_devkit::synth::hash01(x as i32, y as i32, 3) * 4.0
            })
        })
        .flat_map(f32::to_le_bytes)
        .collect()
}

fn pipeline(edge: &str) -> String {
    let job = |id: &str, tile: &str| {
        format!(
            r#"Horizon(id: "{id}", input: "map.r32", raw_size: (150, 110), texel_size: (2, 3), directions: 12,
               edge: {edge}, max_distance: 40, near_field: 6, ao: true{tile}),"#
        )
    };
    format!(r#"(output: "bundle", jobs: [{} {}])"#, job("whole", ""), job("tiled", ", tile: 64"))
}

fn setup(name: &str, edge: &str) -> Dir {
    let dir = Dir::new(name);
    dir.write("map.r32", map_bytes());
    dir.write("pipeline.ron", pipeline(edge));
    dir
}

/// Texel (x, y) of layer `k` of `t`, as bytes.
fn texel(t: &TextureData, k: u32, x: u32, y: u32) -> &[u8] {
    let tb = t.desc.format.texel_bytes();
    let at = ((k as usize * t.desc.height as usize + y as usize) * t.desc.width as usize + x as usize) * tb;
    &t.levels[0][at..at + tb]
}

/// Every tile of `tiled` holds the bytes of the same region of `whole`, for each asset kind.
fn tiles_match(bundle: &Bundle) -> usize {
    let mut compared = 0;
    // Tiles every 64 texels, each 65 wide (the next tile's first column and row too).
    for (ty, tx) in (0..(H - 1).div_ceil(64)).flat_map(|ty| (0..(W - 1).div_ceil(64)).map(move |tx| (ty, tx))) {
        for kind in ["height", "horizon", "ao"] {
            let id = format!("tiled.{kind}.{tx}_{ty}");
            let tile = bundle.read_texture(&id).unwrap();
            let whole = bundle.read_texture(&format!("whole.{kind}")).unwrap();
            let (ox, oy) = (tx * 64, ty * 64);
            assert_eq!((tile.desc.width, tile.desc.height), (65.min(W - ox), 65.min(H - oy)), "{id}");
            let placement = match &bundle.asset(&id).unwrap().settings {
                Settings::Horizon(h) => h.tile.clone(),
                Settings::Heightfield(h) => h.tile.clone(),
                Settings::AmbientOcclusion(a) => {
                    assert_eq!(a.horizon, format!("tiled.horizon.{tx}_{ty}"));
                    None
                }
                other => panic!("{id}: {other:?}"),
            };
            if kind != "ao" {
                let p = placement.unwrap_or_else(|| panic!("{id} has no placement"));
                assert_eq!((p.map.as_str(), p.index, p.origin, p.map_size), ("tiled", (tx, ty), (ox, oy), (W, H)));
            }
            for k in 0..tile.desc.depth {
                for y in 0..tile.desc.height {
                    for x in 0..tile.desc.width {
                        assert_eq!(
                            texel(&tile, k, x, y),
                            texel(&whole, k, ox + x, oy + y),
                            "{id}: layer {k}, texel ({x}, {y})"
                        );
                        compared += 1;
                    }
                }
            }
        }
    }
    compared
}

#[test]
fn tiles_of_a_pipeline_are_the_whole_maps_bytes_and_placed() {
    for edge in ["Wrap", "Clamp"] {
        let dir = setup(&format!("tiles_{edge}"), edge);
        dir.run(&["bake"]);
        dir.run(&["validate", "bundle"]);
        let bundle = Bundle::open(&dir.path("bundle")).unwrap();
        // Every texel, plus the columns and rows two tiles share.
        let (cols, rows) = (W + (W - 1).div_ceil(64) - 1, H + (H - 1).div_ceil(64) - 1);
        assert_eq!(tiles_match(&bundle), (cols * rows * (12 + 2)) as usize, "{edge}");
        // A second run keeps every tile.
        let out = crate::util::stdout(&dir.run(&["bake"]));
        assert!(out.contains("baked 0"), "{out}");
    }
}

#[test]
fn tiles_spread_over_shards_merge_into_the_one_machine_bundle() {
    let whole = setup("tiles_shard_whole", "Clamp");
    whole.run(&["bake"]);
    let parts: Vec<Dir> = (0..3).map(|k| setup(&format!("tiles_shard_{k}"), "Clamp")).collect();
    let mut paths = Vec::new();
    for (k, part) in parts.iter().enumerate() {
        part.run(&["bake", "--shard", &format!("{k}/3")]);
        paths.push(part.path("bundle").display().to_string());
    }
    let merged = Dir::new("tiles_shard_merged");
    let mut args = vec!["merge", "out"];
    args.extend(paths.iter().map(String::as_str));
    merged.run(&args);
    assert_eq!(merged.bundle_files("out"), whole.bundle_files("bundle"), "merged tiles differ from one machine's");
}

#[test]
fn tiling_without_max_distance_is_refused_before_anything_is_read() {
    let dir = Dir::new("tiles_refused");
    dir.write("pipeline.ron", r#"(output: "bundle", jobs: [Horizon(id: "t", input: "missing.r32", tile: 64)])"#);
    let out = dir.run_expecting(&["bake"], 1);
    assert!(stderr(&out).contains("max_distance"), "{}", dir.explain(&["bake"], &out, "max_distance"));
    assert!(!dir.path("bundle").exists());
}

#[test]
fn a_halo_too_large_to_read_is_refused_before_allocating() {
    // max_distance 1e9 texels on a torus: each window would be billions of texels wide.
    let dir = setup("tiles_huge_halo", "Wrap");
    dir.write(
        "pipeline.ron",
        r#"(output: "bundle", jobs: [Horizon(id: "t", input: "map.r32", raw_size: (150, 110), max_distance: 1e9, tile: 64)])"#,
    );
    let out = dir.run_expecting(&["bake"], 1);
    let needle = "above the limit of 16384: lower tile or max_distance";
    assert!(stderr(&out).contains(needle), "{}", dir.explain(&["bake"], &out, needle));
}
