//! What tiles cost against their texels (issue 51): a 1024² map, 16 directions, `max_distance`
//! 64 texels, baked whole and as tiles of 16² to 256², every tile from its own window of
//! heights (its halo cut from the map, as the tiled bake reads it), tiles one after another
//! with the directions of each on every thread, the tiles' time summed. A tile sweeps the lines
//! that cross it, from a block of the reach beyond it, so its cost should be about
//! `1 + max_distance / tile` times its own texels'. The whole map without `max_distance` too.
//! Best of 3.

use hikage_bake::heightfield::Heightfield;
use hikage_bake::horizon::{self, HorizonParams, Rect, TileWindow};
use hikage_bundle::EdgeMode;
use hikage_devkit::synth;

use crate::best_of;

const SIDE: u32 = 1024;
const MAX_DISTANCE: f32 = 64.0;

/// The heights of `place`'s window, cut from `map` (a clamped map: the window lies inside it).
fn cut(map: &Heightfield, place: &TileWindow) -> Heightfield {
    let Rect { x, y, width, height } = place.window;
    let (x, y) = (x as usize, y as usize);
    let samples = (y..y + height as usize)
        .flat_map(|r| map.samples[r * map.width as usize + x..][..width as usize].iter().copied())
        .collect();
    let mut window = Heightfield::from_samples(width, height, samples);
    (window.texel_size, window.height_scale) = (map.texel_size, map.height_scale);
    window
}

pub fn run() {
    let threads = rayon::current_num_threads();
    let mut map = Heightfield::from_samples(SIDE, SIDE, synth::terrain(SIDE));
    map.height_scale = 120.0;
    let params = HorizonParams {
        directions: 16,
        edge: EdgeMode::Clamp,
        max_distance: Some(MAX_DISTANCE),
        ..HorizonParams::default()
    };
    let silent = |_: u64, _: u64| {};
    let (whole, _) = best_of(3, || horizon::bake(&map, &params, &silent).expect("valid settings"));
    let unbounded = HorizonParams { max_distance: None, ..params.clone() };
    let (open, _) = best_of(3, || horizon::bake(&map, &unbounded, &silent).expect("valid settings"));
    println!(
        "Tiles against their texels: {SIDE}² map, 16 directions, {:?}, clamped, max_distance {MAX_DISTANCE} texels, \
         {threads} threads, best of 3; tiles baked one after another from their windows (cut outside the timing)\n",
        params.format
    );
    println!("| bake | tiles | window of a tile | time | baseline | ratio | `1 + max_distance / tile` |");
    println!("|---|---|---|---|---|---|---|");
    println!("| whole map, max_distance {MAX_DISTANCE} | 1 | — | {whole:.3} s | — | — | — |");
    println!(
        "| whole map, no max_distance | 1 | — | {open:.3} s | whole map, max_distance {MAX_DISTANCE} | {:.2}× | — |",
        open / whole
    );
    let halo = horizon::halo(&params, map.texel_size).expect("a max_distance");
    for tile in [16u32, 32, 64, 128, 256] {
        let windows: Vec<(TileWindow, Heightfield)> = (0..SIDE)
            .step_by(tile as usize)
            .flat_map(|y| (0..SIDE).step_by(tile as usize).map(move |x| Rect::new(x, y, tile, tile)))
            .map(|rect| {
                let place = TileWindow::new((SIDE, SIDE), rect, halo, params.edge);
                (place, cut(&map, &place))
            })
            .collect();
        let (t, _) = best_of(3, || {
            for (place, window) in &windows {
                horizon::bake_tile(window, place, &params, &silent).expect("valid settings");
            }
        });
        println!(
            "| {tile}² tiles | {} | {}² | {t:.3} s | whole map, {whole:.3} s | **{:.2}×** | {:.2} |",
            windows.len(),
            tile + 2 * halo.0,
            t / whole,
            1.0 + MAX_DISTANCE as f64 / tile as f64
        );
    }
    println!();
}
