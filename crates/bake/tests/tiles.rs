//! Tiled horizon bakes against the whole-map bake: every tile, baked from its own window of
//! heights (cut here from the map, around the torus on wrapped maps), must hold exactly the
//! bytes of the same region of the whole map's texture.

use hikage_bake::heightfield::Heightfield;
use hikage_bake::horizon::{self, HorizonFormat, HorizonParams, Rect, TileWindow};
use hikage_bundle::EdgeMode;
use hikage_devkit::synth;

fn silent(_: u64, _: u64) {}

/// A map with world units.
fn field(w: u32, h: u32, samples: Vec<f32>, texel: (f32, f32), scale: f32) -> Heightfield {
    let mut hf = Heightfield::from_samples(w, h, samples);
    hf.texel_size = texel;
    hf.height_scale = scale;
    hf
}

/// Rough noise quantised to a few levels: flat plateaus where many samples tie, the hardest case
/// for agreeing on which of equally steep samples is the horizon.
fn terraces(w: u32, h: u32, levels: f32, seed: u32) -> Vec<f32> {
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (synth::hash01(x as i32, y as i32, seed) * levels).floor() / levels))
        .collect()
}

/// The window of `place` cut from `map` by hand: texel (x, y) of the window is map texel
/// (window origin + (x, y)) wrapped into the map.
fn cut(map: &Heightfield, place: &TileWindow) -> Heightfield {
    let Rect { x: wx, y: wy, width: ww, height: wh } = place.window;
    let mut samples = Vec::new();
    for y in 0..wh as i64 {
        for x in 0..ww as i64 {
            let u = (wx + x).rem_euclid(map.width as i64) as u32;
            let v = (wy + y).rem_euclid(map.height as i64) as u32;
            samples.push(map.sample(u, v));
        }
    }
    Heightfield { width: ww, height: wh, samples, ..map.clone() }
}

/// Bakes `map` whole and in `tile`-sized tiles and compares every tile with its region.
/// Returns the number of tiles compared.
fn tiles_equal_whole(name: &str, map: &Heightfield, params: &HorizonParams, tile: u32) -> usize {
    let whole = horizon::bake(map, params, &silent).unwrap();
    let tb = params.format.texture_format().texel_bytes();
    let (w, h, d) = (map.width, map.height, params.directions as usize);
    let halo = horizon::halo(params, map.texel_size).unwrap();
    let mut tiles = 0;
    for ty in (0..h).step_by(tile as usize) {
        for tx in (0..w).step_by(tile as usize) {
            let rect = Rect::new(tx, ty, tile.min(w - tx), tile.min(h - ty));
            let place = TileWindow::new((w, h), rect, halo, params.edge);
            let window = cut(map, &place);
            let baked = horizon::bake_tile(&window, &place, params, &silent).unwrap();
            assert_eq!(baked.distance_scale, whole.distance_scale, "{name}");
            let (tw, th) = (rect.width as usize, rect.height as usize);
            assert_eq!((baked.texture.desc.width, baked.texture.desc.height), (rect.width, rect.height));
            let got = &baked.texture.levels[0];
            let all = &whole.texture.levels[0];
            for k in 0..d {
                for r in 0..th {
                    for c in 0..tw {
                        let at = ((k * th + r) * tw + c) * tb;
                        let from = ((k * h as usize + ty as usize + r) * w as usize + tx as usize + c) * tb;
                        assert_eq!(
                            got[at..at + tb],
                            all[from..from + tb],
                            "{name}: tile at ({tx}, {ty}), direction {k}, texel ({}, {}) differs from the whole map",
                            tx as usize + c,
                            ty as usize + r
                        );
                    }
                }
            }
            tiles += 1;
        }
    }
    tiles
}

fn params(directions: u32, edge: EdgeMode, max_distance: f32, near_field: u32, format: HorizonFormat) -> HorizonParams {
    HorizonParams { directions, edge, max_distance: Some(max_distance), near_field, format }
}

#[test]
fn tiles_of_rough_terrain_are_the_whole_maps_bytes_in_both_edge_modes() {
    let map = field(96, 96, synth::terrain(96), (80.0, 30.0), 1500.0);
    let mut tiles = 0;
    for edge in [EdgeMode::Wrap, EdgeMode::Clamp] {
        for (d, md, near) in [(16, 900.0, 16), (7, 1300.0, 4), (12, 200.0, 16)] {
            let p = params(d, edge, md, near, HorizonFormat::Rg16Float);
            tiles += tiles_equal_whole(&format!("terrain {edge:?} D={d} md={md}"), &map, &p, 40);
        }
    }
    assert_eq!(tiles, 2 * 3 * 9);
}

#[test]
fn tiles_of_terraces_with_many_equal_slopes_are_the_whole_maps_bytes() {
    // An oblong map of flat plateaus: equal slopes everywhere, in every storage format.
    let map = field(77, 53, terraces(77, 53, 3.0, 7), (1.0, 1.0), 9.0);
    for edge in [EdgeMode::Wrap, EdgeMode::Clamp] {
        for format in [HorizonFormat::Rg8Unorm, HorizonFormat::Rg16Float, HorizonFormat::Rg32Float] {
            for (d, md, near) in [(24, 17.5, 6), (5, 30.0, 0), (32, 9.0, 16)] {
                let p = params(d, edge, md, near, format);
                tiles_equal_whole(&format!("terraces {edge:?} {format:?} D={d} md={md} near={near}"), &map, &p, 16);
            }
        }
    }
}

#[test]
fn a_map_smaller_than_its_halo_tiles_around_the_torus() {
    // The halo (40 texels) is larger than the map: a tile's window repeats the map around the
    // torus, as the whole-map bake's rays do.
    let map = field(24, 20, synth::terrain(24).into_iter().take(24 * 20).collect(), (1.0, 1.0), 12.0);
    let p = params(16, EdgeMode::Wrap, 37.0, 16, HorizonFormat::Rg32Float);
    tiles_equal_whole("small torus", &map, &p, 8);
}

#[test]
fn tiling_without_max_distance_is_refused_by_name() {
    let p = HorizonParams { max_distance: None, ..HorizonParams::default() };
    let err = horizon::halo(&p, (1.0, 1.0)).unwrap_err();
    assert!(err.contains("max_distance"), "{err}");
}

#[test]
fn a_window_without_its_halo_is_refused() {
    let map = field(64, 64, synth::terrain(64), (1.0, 1.0), 30.0);
    let p = params(8, EdgeMode::Wrap, 10.0, 4, HorizonFormat::Rg16Float);
    let place = TileWindow::new((64, 64), Rect::new(16, 16, 16, 16), (4, 4), EdgeMode::Wrap);
    let err = horizon::bake_tile(&cut(&map, &place), &place, &p, &silent).unwrap_err();
    assert!(err.contains("halo"), "{err}");
}
