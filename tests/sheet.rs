//! `hikage sheet`: the contact sheet of the default bundle (every asset pictured, each picture a
//! PNG the page names, under 2 MB), and of a changed bake beside its old one (old, new and the
//! difference for each changed asset, which shows where the change is).

use crate::util::{Dir, default_bake, stdout};

/// The `src` of every `<img>` in `page`.
fn images(page: &str) -> Vec<String> {
    page.split("<img src=\"").skip(1).map(|s| s[..s.find('"').unwrap()].to_string()).collect()
}

#[test]
fn the_default_bundle_has_a_picture_of_every_asset() {
    let dir = Dir::new("sheet_default");
    let bundle = default_bake().0.join("bundle");
    dir.run(&["sheet", bundle.to_str().unwrap(), "--out", "sheet"]);
    let page = String::from_utf8(dir.read("sheet/index.html")).unwrap();
    let manifest = hikage_bundle::Bundle::open(&bundle).unwrap();
    let srcs = images(&page);
    assert_eq!(srcs.len(), manifest.manifest().assets.len(), "{page}");
    let mut total = page.len();
    for (src, asset) in srcs.iter().zip(&manifest.manifest().assets) {
        assert_eq!(src, &format!("new/asset/{}.png", asset.id));
        assert!(page.contains(&format!("<b>{}</b>", asset.id)), "{} not labelled", asset.id);
        let bytes = dir.read(&format!("sheet/{src}"));
        total += bytes.len();
        let picture = image::load_from_memory(&bytes).unwrap_or_else(|e| panic!("{src}: {e}"));
        // Something drawn: not one flat colour.
        let pixels = picture.to_rgb8();
        let first = pixels.get_pixel(0, 0);
        assert!(pixels.pixels().any(|p| p != first), "{src} is blank");
    }
    assert!(page.contains("budget disk"), "the default pipeline's budget is shown");
    assert!(total < 2 << 20, "{total} bytes");
}

#[test]
fn a_changed_texel_shows_old_new_and_where_they_differ() {
    let dir = Dir::new("sheet_changed");
    let ramp = |bump: f32| -> Vec<u8> {
        let mut h: Vec<f32> = (0..64 * 64).map(|i| (i % 64) as f32 / 64.0 * 0.2).collect();
        h[32 * 64 + 32] += bump;
        h.into_iter().flat_map(f32::to_le_bytes).collect()
    };
    for (sub, bump) in [("old", 0.0), ("new", 0.5)] {
        dir.write(&format!("{sub}/t.r32"), ramp(bump));
        dir.write(
            &format!("{sub}/pipeline.ron"),
            r#"(output: "bundle", jobs: [Horizon(id: "t", input: "t.r32", texel_size: (10, 10), height_scale: 100, directions: 16, edge: Clamp)])"#,
        );
        dir.run(&["bake", &format!("{sub}/pipeline.ron")]);
    }
    let out = dir.run(&["sheet", "new/bundle", "--out", "sheet", "--old", "old/bundle"]);
    assert!(stdout(&out).contains("2 assets changed"), "{}", stdout(&out));
    let page = String::from_utf8(dir.read("sheet/index.html")).unwrap();
    let srcs = images(&page);
    for id in ["t.height", "t.horizon"] {
        for file in [format!("old/asset/{id}.png"), format!("diff/asset/{id}.png"), format!("new/asset/{id}.png")] {
            assert!(srcs.contains(&file), "{file} not on the page");
        }
    }
    // The heights' difference is red exactly around the raised texel (the 64² map drawn 3× in
    // a 192² picture), black elsewhere.
    let diff = image::load_from_memory(&dir.read("sheet/diff/asset/t.height.png")).unwrap().to_rgb8();
    let red: Vec<(u32, u32)> = diff.enumerate_pixels().filter(|(_, _, p)| p[0] > 0).map(|(x, y, _)| (x, y)).collect();
    assert!(!red.is_empty());
    assert!(red.iter().all(|&(x, y)| (x / 3).abs_diff(32) <= 1 && (y / 3).abs_diff(32) <= 1), "{red:?}");
}

/// A map baked in tiles gets one card per part and level, its tiles' pictures placed in one
/// mosaic of the level's map, not a card per tile payload; with the old bake, a changed tile
/// shows in its level's old, new and difference mosaics. Every picture lives under its role
/// (`new/`, `old/`, `diff/`) and kind (`asset/`, `map/`), so no asset's name can meet another
/// picture's file.
#[test]
fn a_tiled_map_is_one_mosaic_per_part_and_level() {
    let dir = Dir::new("sheet_tiled");
    let heights = |bump: f32| -> Vec<u8> {
        let mut h: Vec<f32> = (0..256 * 256).map(|i| ((i % 256) as f32 * 0.05).sin() * 0.2 + 0.5).collect();
        h[100 * 256 + 200] += bump;
        h.into_iter().flat_map(f32::to_le_bytes).collect()
    };
    for (sub, bump) in [("old", 0.0), ("new", 0.4)] {
        dir.write(&format!("{sub}/dem.r32"), heights(bump));
        dir.write(
            &format!("{sub}/pipeline.ron"),
            r#"(output: "bundle", jobs: [Horizon(id: "dem", input: "dem.r32", texel_size: (10, 10), height_scale: 300,
                directions: 8, edge: Clamp, max_distance: 200, ao: true, tile: 24, levels: 16)])"#,
        );
        dir.run(&["bake", &format!("{sub}/pipeline.ron")]);
    }
    let bundle = hikage_bundle::Bundle::open(&dir.path("new/bundle")).unwrap();
    let tiles = bundle.manifest().assets.len();
    let levels: std::collections::BTreeSet<u32> =
        bundle.manifest().assets.iter().filter_map(|a| a.settings.tile()).map(|p| p.level).collect();
    assert!(tiles > 300 && levels.len() >= 4, "{tiles} payloads, {levels:?}");
    let out = dir.run(&["sheet", "new/bundle", "--out", "sheet", "--old", "old/bundle"]);
    let page = String::from_utf8(dir.read("sheet/index.html")).unwrap();
    let srcs = images(&page);
    let news: Vec<&String> = srcs.iter().filter(|s| s.starts_with("new/")).collect();
    assert_eq!(news.len(), 3 * levels.len(), "one mosaic per part and level: {news:?}");
    for part in ["dem.height", "dem.horizon", "dem.ao"] {
        for level in &levels {
            let file = format!("new/map/{part}.L{level}.png");
            assert!(news.iter().any(|s| **s == file), "{file} missing");
            let picture = image::load_from_memory(&dir.read(&format!("sheet/{file}"))).unwrap().to_rgb8();
            let first = picture.get_pixel(0, 0);
            assert!(picture.pixels().any(|p| p != first), "{file} is blank");
        }
        assert!(page.contains(&format!("<b>{part} level 0</b>")), "{part} not labelled");
    }
    // The raised texel's tile changed at level 0: its mosaics old and new, and their difference
    // red around the texel (the 256² level drawn at 2× in a 512² mosaic), black elsewhere.
    assert!(stdout(&out).contains("changed"), "{}", stdout(&out));
    assert!(srcs.contains(&"old/map/dem.height.L0.png".to_string()), "{srcs:?}");
    let diff = image::load_from_memory(&dir.read("sheet/diff/map/dem.height.L0.png")).unwrap().to_rgb8();
    let red: Vec<(u32, u32)> = diff.enumerate_pixels().filter(|(_, _, p)| p[0] > 0).map(|(x, y, _)| (x, y)).collect();
    assert!(!red.is_empty());
    assert!(red.iter().all(|&(x, y)| (x / 2).abs_diff(200) <= 2 && (y / 2).abs_diff(100) <= 2), "{red:?}");
    let total: u64 = walk(&dir.path("sheet"));
    assert!(total < 2 << 20, "{total} bytes");
}

/// Bytes of every file under `dir`.
fn walk(dir: &std::path::Path) -> u64 {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            if e.file_type().unwrap().is_dir() { walk(&e.path()) } else { e.metadata().unwrap().len() }
        })
        .sum()
}
