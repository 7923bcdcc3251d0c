//! Manifests of maps baked in tiles (issue 38): a square map in 512² tiles with every level of
//! detail and three payloads a tile (heights, horizons, occlusion), from 4096² to 65536². The
//! tile-table manifest (format 1.9: `bundle.ron` and one table file) against every tile listed
//! as its own entry (format 1.8), both written and opened here: bytes; `Bundle::open` (every
//! tile listed as an asset) and `TileIndex::open` (what a streaming game opens: the tables
//! checked, entries built on demand), best of 5 with the page cache warm; one tile found with
//! `TileIndex::tile` and with `tiles::find_tile` (reading nothing but the records it probes).

use hikage_bundle::{Bundle, Limits, Manifest};
use hikage_devkit::tile_tables::{Parts, pyramid};

use crate::best_of;

pub fn run() {
    println!("Tile manifests: 512² tiles, every level, 3 payloads a tile; open = Bundle::open, best of 5\n");
    println!(
        "| map | tiles | payloads | bundle.ron + table | Bundle::open | TileIndex::open | one tile: TileIndex::tile | find_tile | one entry each: bundle.ron | Bundle::open | bytes vs one entry each | Bundle::open vs | TileIndex::open vs |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let scratch = std::env::temp_dir().join(format!("hikage-bench-tiles-{}", std::process::id()));
    let hash = |id: &str| blake3::hash(id.as_bytes()).to_hex().to_string();
    let limits = Limits { max_manifest_bytes: 1 << 30, max_assets: 1 << 20, ..Limits::default() };
    let mib = |b: usize| b as f64 / (1024.0 * 1024.0);
    for size in [4096u32, 8192, 16384, 32768, 65536] {
        let mut manifest = Manifest::new();
        manifest.assets = pyramid("dem", size, 512, Parts::All, 1 << 20, &hash);
        manifest.assets.sort_by(|a, b| a.id.cmp(&b.id));
        let payloads = manifest.assets.len();
        let dir = scratch.join(format!("{size}"));
        std::fs::create_dir_all(&dir).expect("scratch");
        let (text, tables) = manifest.encode();
        std::fs::write(dir.join("bundle.ron"), &text).expect("scratch");
        let table_bytes: usize = tables.iter().map(|(_, b)| b.len()).sum();
        for (name, bytes) in &tables {
            std::fs::write(dir.join(name), bytes).expect("scratch");
        }
        let (open, bundle) = best_of(5, || Bundle::open_with_limits(&dir, limits).expect("opens"));
        assert_eq!(bundle.manifest().assets.len(), payloads);
        let sets = Manifest::tile_sets(&text, &dir.join("bundle.ron")).expect("parses");
        let last = (size / 512 - 1, size / 512 - 1);
        let (find, tile) =
            best_of(5, || hikage_bundle::tiles::find_tile(&dir, &sets[0], "dem.horizon", 0, last).expect("reads"));
        assert!(tile.is_some());
        let (index_open, index) =
            best_of(5, || hikage_bundle::tile_index::TileIndex::open_with_limits(&dir, limits).expect("opens"));
        let (lookup, tile) = best_of(5, || index.tile("dem.horizon", 0, last));
        assert!(tile.is_some());

        // Format 1.8: every tile its own entry.
        let plain_dir = scratch.join(format!("{size}-plain"));
        std::fs::create_dir_all(&plain_dir).expect("scratch");
        let config = ron::ser::PrettyConfig::new().indentor("    ").struct_names(false).compact_arrays(false);
        let plain = ron::ser::to_string_pretty(&manifest, config).expect("serialises");
        std::fs::write(plain_dir.join("bundle.ron"), &plain).expect("scratch");
        let (plain_open, _) = best_of(5, || Bundle::open_with_limits(&plain_dir, limits).expect("opens"));
        let tiles = payloads / 3;
        let ours = text.len() + table_bytes;
        println!(
            "| {size}² | {tiles} | {payloads} | {:.2} MiB ({:.1} KiB + {:.2} MiB) | {:.1} ms | {:.1} ms | {:.1} µs | {:.1} µs | {:.1} MiB | {:.1} ms | {:.3}× | {:.3}× | {:.3}× |",
            mib(ours),
            text.len() as f64 / 1024.0,
            mib(table_bytes),
            open * 1e3,
            index_open * 1e3,
            lookup * 1e6,
            find * 1e6,
            mib(plain.len()),
            plain_open * 1e3,
            ours as f64 / plain.len() as f64,
            open / plain_open,
            index_open / plain_open,
        );
        let _ = std::fs::remove_dir_all(&dir);
        let _ = std::fs::remove_dir_all(&plain_dir);
    }
    let _ = std::fs::remove_dir_all(&scratch);
    println!();
}
