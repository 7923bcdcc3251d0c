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
        assert_eq!(src, &format!("{}.png", asset.id));
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
        for file in [format!("{id}.old.png"), format!("{id}.diff.png"), format!("{id}.png")] {
            assert!(srcs.contains(&file), "{file} not on the page");
        }
    }
    // The heights' difference is red exactly around the raised texel (the 64² map drawn 3× in
    // a 192² picture), black elsewhere.
    let diff = image::load_from_memory(&dir.read("sheet/t.height.diff.png")).unwrap().to_rgb8();
    let red: Vec<(u32, u32)> = diff.enumerate_pixels().filter(|(_, _, p)| p[0] > 0).map(|(x, y, _)| (x, y)).collect();
    assert!(!red.is_empty());
    assert!(red.iter().all(|&(x, y)| (x / 3).abs_diff(32) <= 1 && (y / 3).abs_diff(32) <= 1), "{red:?}");
}
