//! Tiled horizon jobs end to end: `hikage bake` of a pipeline holding one map baked whole and in
//! tiles, every tile's heights, horizons and occlusion against the same region of the whole
//! map's, their placements, and tiles spread over shards and merged; tile tables read back as
//! the entries they were written from, a damaged table refused, 20,000 tiles opened and
//! validated.

use hikage_bundle::tile_index::TileIndex;
use hikage_bundle::{Bundle, BundleError, Manifest, Settings, TextureData};
use hikage_devkit::tile_tables::{Parts, pyramid};

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
        // The tiles are one tile set of bundle.ron with a table, not an entry each.
        let text = String::from_utf8(dir.read("bundle/bundle.ron")).unwrap();
        assert!(text.contains("tile_sets") && text.contains("tiled.tile-table."), "{text}");
        assert!(!text.contains("\"tiled.horizon.0_0\"") && text.contains("\"whole.horizon\""), "{text}");
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

/// 64 hex digits standing for `id`'s hash (only the manifest is read).
fn fake_hash(id: &str) -> String {
    blake3::hash(id.as_bytes()).to_hex().to_string()
}

/// Writes `manifest` into `dir` as a bake would: `bundle.ron` and its tile tables.
fn write_manifest(dir: &Dir, manifest: &Manifest) -> (usize, usize) {
    let (text, tables) = manifest.encode();
    dir.write("b/bundle.ron", &text);
    let mut table_bytes = 0;
    for (name, bytes) in &tables {
        dir.write(&format!("b/{name}"), bytes);
        table_bytes += bytes.len();
    }
    (text.len(), table_bytes)
}

#[test]
fn a_tile_table_reads_back_as_the_entries_it_was_written_from() {
    let dir = Dir::new("tile_table_round_trip");
    let mut manifest = Manifest::new();
    manifest.assets = pyramid("dem", 4096, 256, Parts::All, 1234, &fake_hash);
    // A 4096² map in 256² tiles: 16² + 8² + 4² + 2² + 1 tiles, three payloads each.
    assert_eq!(manifest.assets.len(), 3 * (256 + 64 + 16 + 4 + 1));
    manifest.assets.sort_by(|a, b| a.id.cmp(&b.id));
    let (text, tables) = write_manifest(&dir, &manifest);
    // 100 bytes a payload in the table and a few parts in bundle.ron.
    assert_eq!(tables, 16 + 100 * manifest.assets.len());
    // One part per kind and level (texel size and map size change with the level).
    assert!(text < 32 << 10, "bundle.ron is {text} bytes");
    let bundle = Bundle::open(&dir.path("b")).unwrap();
    assert_eq!(bundle.manifest().assets, manifest.assets);
    // Written again, the same bytes.
    assert_eq!(bundle.manifest().encode(), manifest.encode());

    // One tile without the rest, at each level.
    let text = String::from_utf8(dir.read("b/bundle.ron")).unwrap();
    let sets = Manifest::tile_sets(&text, "b/bundle.ron".as_ref()).unwrap();
    assert_eq!(sets.len(), 1);
    for (part, level, index, id) in [
        ("dem.horizon", 0, (15, 3), "dem.horizon.15_3"),
        ("dem.ao", 2, (3, 1), "dem.ao.L2.3_1"),
        ("dem.height", 4, (0, 0), "dem.height.L4.0_0"),
    ] {
        let found = hikage_bundle::tiles::find_tile(&dir.path("b"), &sets[0], part, level, index).unwrap();
        assert_eq!(found.as_ref(), manifest.asset(id), "{id}");
    }
    let missing = hikage_bundle::tiles::find_tile(&dir.path("b"), &sets[0], "dem.horizon", 0, (16, 0)).unwrap();
    assert!(missing.is_none());
    // The index a streaming game opens gives every tile's entry as the full manifest has it.
    let index = TileIndex::open(&dir.path("b")).unwrap();
    for a in &manifest.assets {
        let p = a.settings.tile().unwrap();
        let part = hikage_bundle::tiles::tile_part(&a.id, p).unwrap();
        assert_eq!(index.tile(part, p.level, p.index).as_ref(), Some(a));
    }
    assert!(index.tile("dem.horizon", 1, (8, 0)).is_none() && index.tile("dem.nothing", 0, (0, 0)).is_none());

    // A damaged table is refused, naming it; so is one cut short.
    let table = &sets[0].table;
    let mut bytes = dir.read(&format!("b/{table}"));
    bytes[16 + 100 * 7 + 40] ^= 1;
    dir.write(&format!("b/{table}"), &bytes);
    for err in [Bundle::open(&dir.path("b")).unwrap_err(), TileIndex::open(&dir.path("b")).unwrap_err()] {
        let err = err.to_string();
        assert!(err.contains(table.as_str()) && err.contains("BLAKE3"), "{err}");
    }
    dir.write(&format!("b/{table}"), &bytes[..bytes.len() - 100]);
    for err in [Bundle::open(&dir.path("b")).unwrap_err(), TileIndex::open(&dir.path("b")).unwrap_err()] {
        let err = err.to_string();
        assert!(err.contains(table.as_str()) && err.contains("bytes"), "{err}");
    }
    // A set claiming more records than readers accept is refused before its table is read.
    let huge = text.replace(&format!("records: {}", manifest.assets.len()), "records: 4000000000");
    dir.write("b/bundle.ron", huge);
    // Both readers alike: one reading of the tables.
    for err in [Bundle::open(&dir.path("b")).unwrap_err(), TileIndex::open(&dir.path("b")).unwrap_err()] {
        match err {
            BundleError::Limit { what, value, .. } => assert!(what.contains("asset count") && value >= 4_000_000_000),
            e => panic!("expected a limit, got {e}"),
        }
    }
}

#[test]
fn twenty_thousand_tiles_open_and_validate() {
    let dir = Dir::new("tile_table_20k");
    // One small heights payload, its bytes in every tile's file.
    let desc = hikage_bundle::TextureDesc {
        format: hikage_bundle::TextureFormat::R32Float,
        dimension: hikage_bundle::TextureDimension::D2,
        width: 2,
        height: 2,
        depth: 1,
        layers: 1,
        levels: 1,
        supercompression: hikage_bundle::Supercompression::None,
        channels: vec!["height".into()],
    };
    let texture = TextureData::from_f32(desc, &[1.0, 2.0, 3.0, 4.0]).unwrap();
    let bytes = hikage_bundle::ktx2_file::encode(&texture, hikage_bundle::GENERATOR).unwrap();
    let hash = blake3::hash(&bytes).to_hex().to_string();
    // 141² tiles of 1 texel (each 2² with its neighbour's column and row): 19,881 at level 0,
    // about 26,500 with every level.
    let mut manifest = Manifest::new();
    manifest.assets = pyramid("big", 141, 1, Parts::Heights, bytes.len() as u64, &|_| hash.clone())
        .into_iter()
        .filter(|a| a.payload.texture().is_some_and(|t| (t.width, t.height) == (2, 2)))
        .collect();
    manifest.assets.sort_by(|a, b| a.id.cmp(&b.id));
    assert!(manifest.assets.len() >= 20_000, "{}", manifest.assets.len());
    for a in &manifest.assets {
        dir.write(&format!("b/{}", a.file), &bytes);
    }
    let (text, _) = write_manifest(&dir, &manifest);
    assert!(text < 32 << 10, "bundle.ron is {text} bytes");
    let bundle = Bundle::open(&dir.path("b")).unwrap();
    assert_eq!(bundle.manifest().assets.len(), manifest.assets.len());
    let report = hikage_bundle::validate(&dir.path("b")).unwrap();
    assert!(
        report.is_valid() && report.assets == manifest.assets.len(),
        "{:?}",
        &report.problems[..3.min(report.problems.len())]
    );
    // The CLI's validate agrees.
    dir.run(&["validate", "b"]);
    // One tile through the index a streaming game opens.
    let index = TileIndex::open(&dir.path("b")).unwrap();
    let tile = index.tile("big.height", 0, (139, 138)).unwrap();
    assert_eq!(index.read_texture(&tile).unwrap(), texture);
}

/// The 150×110 map reduced by `2^level` as the pyramid's rule says, computed here on its own:
/// node (i, j) is the mean height within 2^(level-1) texels of texel (i·s, j·s), summed row by
/// row in f64.
fn reduced(map: &[f32], level: u32) -> (u32, u32, Vec<f32>) {
    let s = 1i64 << level;
    let (w, h) = (((W - 1) as i64 / s + 1) as u32, ((H - 1) as i64 / s + 1) as u32);
    let mut out = Vec::new();
    for j in 0..h as i64 {
        for i in 0..w as i64 {
            let (mut sum, mut n) = (0f64, 0);
            for y in (j * s - s / 2).max(0)..=(j * s + s / 2).min(H as i64 - 1) {
                let xs = (i * s - s / 2).max(0)..=(i * s + s / 2).min(W as i64 - 1);
                n += xs.clone().count();
                sum += xs.map(|x| map[(y * W as i64 + x) as usize] as f64).sum::<f64>();
            }
            out.push((sum / n as f64) as f32);
        }
    }
    (w, h, out)
}

#[test]
fn each_level_of_a_pyramid_is_the_reduced_maps_whole_bake() {
    let dir = Dir::new("tiles_levels");
    let bytes = map_bytes();
    dir.write("map.r32", &bytes);
    dir.write(
        "pipeline.ron",
        r#"(output: "bundle", jobs: [Horizon(id: "lod", input: "map.r32", raw_size: (150, 110), texel_size: (2, 3),
            directions: 12, edge: Clamp, max_distance: 40, near_field: 6, ao: true, tile: 32, levels: 9)])"#,
    );
    dir.run(&["bake"]);
    dir.run(&["validate", "bundle"]);
    let bundle = Bundle::open(&dir.path("bundle")).unwrap();
    let map: Vec<f32> = bytes.chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect();
    // 150×110 in 32² tiles: 5×4, then 75×55 (3×2), 38×28 (2×1), 19×14 (1×1, the last level).
    let mut tiles = 0;
    for (level, grid) in [(0, (5, 4)), (1, (3, 2)), (2, (2, 1)), (3, (1, 1))] {
        let (w, h, heights) = reduced(&map, level);
        let s = (1 << level) as f32;
        let mut hf = hikage_bake::heightfield::Heightfield::from_samples(w, h, heights.clone());
        hf.texel_size = (2.0 * s, 3.0 * s);
        let params = hikage_bake::horizon::HorizonParams {
            directions: 12,
            edge: hikage_bundle::EdgeMode::Clamp,
            max_distance: Some(40.0),
            near_field: 6,
            ..Default::default()
        };
        let whole = hikage_bake::horizon::bake(&hf, &params, &|_, _| {}).unwrap().texture;
        for (tx, ty) in (0..grid.1).flat_map(|ty| (0..grid.0).map(move |tx| (tx, ty))) {
            let suffix = hikage_bundle::tiles::tile_suffix(level, (tx, ty));
            let horizon = bundle.read_texture(&format!("lod.horizon{suffix}")).unwrap();
            let height = bundle.read_texture(&format!("lod.height{suffix}")).unwrap();
            let place = bundle.asset(&format!("lod.horizon{suffix}")).unwrap().settings.tile().unwrap().clone();
            assert_eq!((place.level, place.index, place.map_size), (level, (tx, ty), (w, h)), "{suffix}");
            let (ox, oy) = (tx * 32, ty * 32);
            assert_eq!(place.origin, (ox, oy));
            assert_eq!((horizon.desc.width, horizon.desc.height), (33.min(w - ox), 33.min(h - oy)), "{suffix}");
            for y in 0..horizon.desc.height {
                for x in 0..horizon.desc.width {
                    let at = ((oy + y) * w + ox + x) as usize;
                    let got = f32::from_le_bytes(texel(&height, 0, x, y).try_into().unwrap());
                    assert_eq!(got, heights[at], "height {suffix} ({x}, {y})");
                    for k in 0..12 {
                        let want = texel(&whole, k, ox + x, oy + y);
                        assert_eq!(texel(&horizon, k, x, y), want, "horizon {suffix} ({x}, {y}) direction {k}");
                    }
                }
            }
            tiles += 1;
        }
    }
    assert_eq!(tiles, 20 + 6 + 2 + 1);
    assert_eq!(bundle.manifest().assets.len(), tiles * 3, "no level past the one-tile level");
    // A torus needs sides that halve: 150×110 has no level 2.
    let wrapped = r#"(output: "bundle", jobs: [Horizon(id: "lod", input: "map.r32", raw_size: (150, 110),
        edge: Wrap, max_distance: 40, tile: 32, levels: 3)])"#;
    dir.write("pipeline.ron", wrapped);
    let err = stderr(&dir.run_expecting(&["bake"], 1));
    assert!(err.contains("lod") && err.contains("has no level 2") && err.contains("multiples of 4"), "{err}");
}

/// An edit of a small rectangle of the input rebakes exactly the tiles whose windows (the tile,
/// its halo and border, at its level; a coarser level's traced back to the level-0 texels its
/// nodes average) hold an edited sample, computed here from the windows' rule on its own; the
/// bundle is then byte for byte a fresh bake of the edited map.
#[test]
fn an_edit_rebakes_only_the_tiles_whose_windows_it_touches() {
    let dir = Dir::new("tiles_edit");
    let pipeline = r#"(output: "bundle", jobs: [Horizon(id: "lod", input: "map.r32", raw_size: (150, 110),
        texel_size: (2, 3), directions: 12, edge: Clamp, max_distance: 40, near_field: 6, ao: true, tile: 32,
        levels: 9)])"#;
    dir.write("pipeline.ron", pipeline);
    let bytes = map_bytes();
    dir.write("map.r32", &bytes);
    dir.run(&["bake"]);
    let hashes = |dir: &Dir| -> std::collections::BTreeMap<String, String> {
        let bundle = Bundle::open(&dir.path("bundle")).unwrap();
        bundle.manifest().assets.iter().map(|a| (a.id.clone(), a.input_hash.clone())).collect()
    };
    let before = hashes(&dir);
    // Raise texels x 120–123, y 8–10 (level 0) by 5.
    let edit = (120u32..124, 8u32..11);
    let mut map: Vec<f32> = bytes.chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect();
    for y in edit.1.clone() {
        for x in edit.0.clone() {
            map[(y * W + x) as usize] += 5.0;
        }
    }
    let edited: Vec<u8> = map.iter().flat_map(|v| v.to_le_bytes()).collect();
    dir.write("map.r32", &edited);
    let out = crate::util::stdout(&dir.run(&["bake"]));
    let after = hashes(&dir);
    let rebaked: std::collections::BTreeSet<String> = after
        .iter()
        .filter(|(id, hash)| id.starts_with("lod.horizon") && before.get(*id) != Some(hash))
        .map(|(id, _)| id.clone())
        .collect();
    // The windows, on their own: a tile of 33 texels every 32, grown by ⌈40 / texel⌉ + 3 on
    // each side and kept inside the map; a level-k node covers the level-0 texels within 2^(k-1)
    // of its own.
    let mut expected = std::collections::BTreeSet::new();
    for level in 0..4u32 {
        let s = 1i64 << level;
        let (w, h) = ((W as i64 - 1) / s + 1, (H as i64 - 1) / s + 1);
        let halo = |texel: f64| (40.0 / (texel * s as f64)).ceil() as i64 + 3;
        let (hx, hy) = (halo(2.0), halo(3.0));
        let footprint = |lo: i64, hi: i64, size: i64| ((lo * s - s / 2).max(0), ((hi - 1) * s + s / 2).min(size - 1));
        for ty in 0..((h - 1) as u32).div_ceil(32).max(1) as i64 {
            for tx in 0..((w - 1) as u32).div_ceil(32).max(1) as i64 {
                let (x0, y0) = (tx * 32, ty * 32);
                let (x1, y1) = ((x0 + 33).min(w), (y0 + 33).min(h));
                let (wx, wy) = (
                    footprint((x0 - hx).max(0), (x1 + hx).min(w), W as i64),
                    footprint((y0 - hy).max(0), (y1 + hy).min(h), H as i64),
                );
                let meets = |(lo, hi): (i64, i64), e: &std::ops::Range<u32>| lo < e.end as i64 && e.start as i64 <= hi;
                let hit = meets(wx, &edit.0) && meets(wy, &edit.1);
                if hit {
                    expected.insert(format!(
                        "lod.horizon{}",
                        hikage_bundle::tiles::tile_suffix(level, (tx as u32, ty as u32))
                    ));
                }
            }
        }
    }
    eprintln!(
        "{out}rebaked {} of {} tiles: {rebaked:?}",
        rebaked.len(),
        before.keys().filter(|k| k.starts_with("lod.horizon")).count()
    );
    assert_eq!(rebaked, expected);
    assert!(
        out.contains(&format!("baked {} ({} tiles of lod, input changed (level 0: ", expected.len(), expected.len())),
        "{out}"
    );
    assert!(expected.len() < 29 / 2, "an edit in a corner rebakes a few of the 29 tiles: {expected:?}");
    // Byte for byte a fresh bake of the edited map.
    let fresh = Dir::new("tiles_edit_fresh");
    fresh.write("pipeline.ron", pipeline);
    fresh.write("map.r32", &edited);
    fresh.run(&["bake"]);
    assert_eq!(crate::util::snapshot(&dir.path("bundle")), crate::util::snapshot(&fresh.path("bundle")));
    // `diff --format json` against the bake before the edit names each changed tile's map, level
    // and texels: rebaked tiles whose output changed, each payload inside its tile's rectangle.
    fresh.write("map.r32", &bytes);
    fresh.write("pipeline.ron", pipeline.replace(r#"output: "bundle""#, r#"output: "before""#));
    fresh.run(&["bake"]);
    let out = fresh.run_expecting(&["diff", "before", "bundle", "--format", "json"], 1);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let changed = report["assets"].as_array().unwrap();
    assert!(!changed.is_empty());
    for a in changed {
        let (id, tile) = (a["id"].as_str().unwrap(), &a["tile"]);
        let level = tile["level"].as_u64().unwrap() as u32;
        let index = (tile["index"][0].as_u64().unwrap() as u32, tile["index"][1].as_u64().unwrap() as u32);
        let suffix = hikage_bundle::tiles::tile_suffix(level, index);
        assert!(expected.contains(&format!("lod.horizon{suffix}")), "{id} changed but was not rebaked");
        assert!(id.ends_with(&suffix) && tile["map"] == "lod", "{a}");
        let rect: Vec<u64> = tile["rect"].as_array().unwrap().iter().map(|v| v.as_u64().unwrap()).collect();
        assert_eq!(rect[..2], [index.0 as u64 * 32, index.1 as u64 * 32], "{a}");
    }
}

/// The stream's tile reader and the bundle's reader count the same assets against
/// `max_assets`, plain entries and tiles together, and refuse a bundle past it alike: as a
/// limit, naming the table.
#[test]
fn both_readers_count_plain_assets_and_tiles_against_the_limit() {
    let dir = setup("tiles_limit", "Clamp");
    dir.run(&["bake"]);
    let all = Bundle::open(&dir.path("bundle")).unwrap().manifest().assets.len();
    let at = |max_assets: usize| hikage_bundle::Limits { max_assets, ..hikage_bundle::Limits::default() };
    assert!(Bundle::open_with_limits(&dir.path("bundle"), at(all)).is_ok());
    assert!(TileIndex::open_with_limits(&dir.path("bundle"), at(all)).is_ok());
    for error in [
        Bundle::open_with_limits(&dir.path("bundle"), at(all - 1)).err(),
        TileIndex::open_with_limits(&dir.path("bundle"), at(all - 1)).err(),
    ] {
        let error = error.expect("refused past the limit");
        assert!(matches!(error, BundleError::Limit { .. }), "{error}");
        assert!(error.to_string().contains("tile-table") && error.to_string().contains(&all.to_string()), "{error}");
    }
}

/// The table and `bundle.ron` of `dir/b` with the table's records changed by `edit` (and the
/// manifest's hash, name and length of the table kept in step), as a hostile writer would.
fn edit_records(dir: &Dir, edit: impl FnOnce(&mut Vec<[u8; 100]>)) {
    let text = String::from_utf8(dir.read("b/bundle.ron")).unwrap();
    let set = Manifest::tile_sets(&text, "b/bundle.ron".as_ref()).unwrap().remove(0);
    let bytes = dir.read(&format!("b/{}", set.table));
    let mut records: Vec<[u8; 100]> = bytes[16..].chunks_exact(100).map(|c| c.try_into().unwrap()).collect();
    edit(&mut records);
    let mut table = bytes[..16].to_vec();
    records.iter().for_each(|r| table.extend_from_slice(r));
    let hash = blake3::hash(&table).to_hex().to_string();
    let name = set.table.replace(&set.blake3, &hash);
    std::fs::remove_file(dir.path(&format!("b/{}", set.table))).unwrap();
    dir.write(&format!("b/{name}"), &table);
    dir.write("b/bundle.ron", text.replace(&set.blake3, &hash));
}

/// What the tile reader relies on is what opening and validating a bundle check, both ways
/// (the full manifest and the streaming index): records in id order (a reader's binary search
/// would miss tiles), each on its level's grid, each naming assets that exist; and tables are
/// never read through a symbolic link.
#[test]
fn tile_tables_a_reader_would_misread_are_refused() {
    let refused = |dir: &Dir, want: &str| {
        for err in [Bundle::open(&dir.path("b")).unwrap_err(), TileIndex::open(&dir.path("b")).unwrap_err()] {
            let err = err.to_string();
            assert!(err.contains(want) && err.contains("tile-table"), "{want}: {err}");
        }
    };
    let fresh = |name: &str| {
        let dir = Dir::new(name);
        let mut manifest = Manifest::new();
        manifest.assets = pyramid("dem", 1024, 256, Parts::All, 1234, &fake_hash);
        manifest.assets.sort_by(|a, b| a.id.cmp(&b.id));
        write_manifest(&dir, &manifest);
        Bundle::open(&dir.path("b")).unwrap();
        TileIndex::open(&dir.path("b")).unwrap();
        dir
    };
    // Two records swapped: the reader's search would not find them.
    let dir = fresh("tile_table_order");
    edit_records(&dir, |r| r.swap(3, 4));
    refused(&dir, "does not come after record 3");
    // A record whose origin is not its grid index's.
    let dir = fresh("tile_table_grid");
    edit_records(&dir, |r| r[5][12..16].copy_from_slice(&7u32.to_le_bytes()));
    refused(&dir, "starts at 7");
    // A horizon part naming heights that are not in the bundle: every horizon tile names none.
    let dir = fresh("tile_table_dependency");
    let text = String::from_utf8(dir.read("b/bundle.ron")).unwrap();
    assert!(text.contains(r#"heightfield: "dem.height""#), "{text}");
    dir.write("b/bundle.ron", text.replace(r#"heightfield: "dem.height""#, r#"heightfield: "dem.nothing""#));
    for err in [Bundle::open(&dir.path("b")).unwrap_err(), TileIndex::open(&dir.path("b")).unwrap_err()] {
        let err = err.to_string();
        assert!(err.contains("dem.nothing") && err.contains("not in the bundle"), "{err}");
    }
    // A table that is a link to a file outside the bundle.
    let dir = fresh("tile_table_link");
    let text = String::from_utf8(dir.read("b/bundle.ron")).unwrap();
    let table = Manifest::tile_sets(&text, "b/bundle.ron".as_ref()).unwrap().remove(0).table;
    std::fs::rename(dir.path(&format!("b/{table}")), dir.path("outside.bin")).unwrap();
    std::os::unix::fs::symlink(dir.path("outside.bin"), dir.path(&format!("b/{table}"))).unwrap();
    refused(&dir, "symbolic link");
}

/// A plain horizon naming a heightfield that is not in the bundle, or an occlusion map naming
/// something other than a horizon, is refused by name.
#[test]
fn an_asset_naming_what_is_not_there_is_refused() {
    let dir = Dir::with_default_bundle("missing_dependency");
    let text = String::from_utf8(dir.read("bundle/bundle.ron")).unwrap();
    assert!(text.contains(r#"heightfield: "dunes.height""#));
    dir.write("bundle/bundle.ron", text.replace(r#"heightfield: "dunes.height""#, r#"heightfield: "dunes.gone""#));
    let err = Bundle::open(&dir.path("bundle")).unwrap_err().to_string();
    assert!(err.contains("dunes.horizon") && err.contains("`dunes.gone`, which is not in the bundle"), "{err}");
    let out = dir.run_expecting(&["validate", "bundle"], 1);
    let said = format!("{}{}", String::from_utf8_lossy(&out.stdout), stderr(&out));
    assert!(said.contains("dunes.horizon") && said.contains("dunes.gone"), "{said}");
    let wrong = text.replace(r#"horizon: "terrain.horizon""#, r#"horizon: "terrain.height""#);
    assert_ne!(wrong, text);
    dir.write("bundle/bundle.ron", wrong);
    let err = Bundle::open(&dir.path("bundle")).unwrap_err().to_string();
    assert!(err.contains("terrain.ao") && err.contains("as its horizon, which is a heightfield"), "{err}");
}
