//! The rule for a point above the ground (far terrain shadows on what stands on the terrain):
//! three ways to get a raised point's sun visibility from the baked horizons, each against an
//! exact march from that point over the heights, within the bake's reach.
//!
//! - **ground**: the horizon of the ground under the point (`tan β`), as if it were not raised;
//! - **occluder at d**: the ground's horizon point seen from the raised point,
//!   `(d·tan β − h) / d`;
//! - **hull walk** (`horizon_raised_sun_visible`): the horizon point's own horizon point, and so
//!   on, the vertices of the profile's upper convex hull, until the slope from the raised point
//!   stops rising.
//!
//! Points: texel centres drawn at random over the map, `h` above the ground there; suns at
//! 2°, 5°, 10°, 20° and 30° from four azimuths that are none of the baked directions. The march
//! (`brute_force::raised_shadow_height`) steps a quarter texel over the bilinear surface (the
//! surface the baker's rays cross) and
//! gives each point and sun the height above which the sun's centre is seen; a rule agrees when
//! it says lit exactly where the point stands above that height.

use hikage_devkit::brute_force;
use hikage_runtime::CpuBundle;
use hikage_runtime::glam::{Vec2, Vec3};
use hikage_runtime::horizon::reference::{HorizonMap, horizon_raised_sun_visible};
use rayon::prelude::*;

/// Heights above the ground, world units (metres here).
const HEIGHTS: [f32; 5] = [0.0, 2.0, 10.0, 30.0, 100.0];
/// Sun elevations, degrees.
const ELEVATIONS: [f32; 5] = [2.0, 5.0, 10.0, 20.0, 30.0];
/// Sun azimuths, degrees from +u toward +v: none on a baked direction.
const AZIMUTHS: [f32; 4] = [7.0, 101.0, 196.0, 289.0];
/// Points a map.
const POINTS: usize = 6000;

/// One map baked and read back: heights, horizons and how far the horizons reach.
struct Map {
    name: String,
    size: (usize, usize),
    texel: Vec2,
    heights: Vec<f32>,
    horizons: HorizonMap,
    reach: f32,
}

impl Map {
    /// The height above the ground at texel `(i, j)` above which the sun's centre at `elevation`
    /// and `azimuth` (radians) is seen, by the brute-force march within the reach.
    fn shadow_height(&self, at: (usize, usize), elevation: f32, azimuth: f32) -> f32 {
        let texel = (self.texel.x, self.texel.y);
        brute_force::raised_shadow_height(&self.heights, self.size, texel, at, (elevation, azimuth), self.reach)
    }
}

/// Bakes `job` (a `Horizon` job with id `t`, inputs relative to `dir`) and reads it back.
fn bake(name: &str, dir: &std::path::Path, job: &str) -> Map {
    std::fs::write(dir.join("pipeline.ron"), format!(r#"(output: "bundle", jobs: [{job}])"#)).expect("the pipeline");
    hikage_bake::run::run_pipeline(&dir.join("pipeline.ron"), &Default::default()).expect("the map bakes");
    let cpu = CpuBundle::read_prefix(&dir.join("bundle"), "t.").expect("the bundle reads");
    let height = cpu.asset("t.height").expect("heights");
    let hs = height.asset.settings.heightfield().expect("a heightfield").clone();
    let texture = height.texture().expect("a texture");
    let heights: Vec<f32> = texture.to_f32(0).iter().map(|v| hs.height_offset + hs.height_scale * v).collect();
    let horizon = cpu.asset("t.horizon").expect("horizons");
    let settings = horizon.asset.settings.horizon().expect("a horizon").clone();
    let horizons = HorizonMap::new(horizon.texture().expect("a texture"), &settings, true).expect("a horizon map");
    let size = (texture.desc.width as usize, texture.desc.height as usize);
    let texel = Vec2::new(hs.texel_size.0, hs.texel_size.1);
    let extent = Vec2::new(size.0 as f32, size.1 as f32) * texel;
    let reach = settings.max_distance.unwrap_or(extent.length());
    Map { name: name.to_string(), size, texel, heights, horizons, reach }
}

/// Agreement of the three rules with the march on `map`, a row per height.
fn rows(map: &Map) {
    // The same points every run: a small LCG over the texels.
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut next = |n: usize| {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((seed >> 33) as usize) % n
    };
    let points: Vec<(usize, usize)> = (0..POINTS).map(|_| (next(map.size.0), next(map.size.1))).collect();
    let suns: Vec<(f32, f32)> =
        ELEVATIONS.iter().flat_map(|&e| AZIMUTHS.iter().map(move |&a| (e.to_radians(), a.to_radians()))).collect();
    // Per sun: each point's shadow height from the march.
    let truth: Vec<Vec<f32>> =
        suns.iter().map(|&(e, a)| points.par_iter().map(|&p| map.shadow_height(p, e, a)).collect()).collect();
    for &h in &HEIGHTS {
        // Per rule: agreeing and lit-where-shadowed counts, and the worst sun's agreement.
        let mut agree = [0usize; 3];
        let mut leaks = [0usize; 3];
        let mut worst = [1.0f64; 3];
        for (s, &(e, a)) in suns.iter().enumerate() {
            let sun = Vec3::new(e.cos() * a.cos(), e.cos() * a.sin(), e.sin());
            let verdicts: Vec<([bool; 3], bool)> = points
                .par_iter()
                .zip(&truth[s])
                .map(|(&(i, j), &needed)| {
                    let uv = Vec2::new((i as f32 + 0.5) / map.size.0 as f32, (j as f32 + 0.5) / map.size.1 as f32);
                    let fetch = hikage_runtime::horizon::reference::horizon_fetch(
                        &map.horizons,
                        uv,
                        hikage_runtime::horizon::reference::horizon_texel_azimuth(sun, map.texel),
                    );
                    let [tan_beta, d] = fetch;
                    let ground = e.tan() > tan_beta;
                    let occluder = if d > 0.0 { e.tan() > (d * tan_beta - h) / d } else { true };
                    let walk = horizon_raised_sun_visible(&map.horizons, uv, sun, map.texel, h, map.reach, 0.0) > 0.5;
                    ([ground, occluder, walk], h > needed)
                })
                .collect();
            for r in 0..3 {
                let ok = verdicts.iter().filter(|(v, lit)| v[r] == *lit).count();
                agree[r] += ok;
                leaks[r] += verdicts.iter().filter(|(v, lit)| v[r] && !*lit).count();
                worst[r] = worst[r].min(ok as f64 / points.len() as f64);
            }
        }
        let total = (points.len() * suns.len()) as f64;
        let cell = |r: usize| {
            format!(
                "{:.2}% ({:.2}%; {:.2}% lit wrongly)",
                100.0 * agree[r] as f64 / total,
                100.0 * worst[r],
                100.0 * leaks[r] as f64 / total
            )
        };
        println!("| {} | {h} m | {} | {} | {} |", map.name, cell(0), cell(1), cell(2));
    }
}

pub fn run() {
    let dir = std::env::temp_dir().join(format!("hikage-bench-raised-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    println!(
        "A point h above the terrain, its sun visibility from the baked horizons against an exact march over the \
         heights within the bake's reach: {POINTS} random texels, suns at {ELEVATIONS:?}° from 4 azimuths off the \
         baked directions. Each cell: agreement over all suns (the worst sun's; lit where the march says shadow)\n"
    );
    println!("| map | h | ground's horizon | occluder at d | hull walk (`horizon_raised_sun_visible`) |");
    println!("|---|---|---|---|---|");
    let heights: Vec<u8> = hikage_devkit::synth::terrain(512).into_iter().flat_map(f32::to_le_bytes).collect();
    std::fs::write(dir.join("dem.r32"), heights).expect("the DEM");
    let generated = bake(
        "rough 512², 30 m texels, 1.2 km relief, reach 6 km, 32 directions",
        &dir,
        r#"Horizon(id: "t", input: "dem.r32", texel_size: (30, 30), height_scale: 1200, directions: 32,
           edge: Clamp, max_distance: 6000)"#,
    );
    rows(&generated);
    let sample = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/terrain.png");
    let sample = bake(
        "sample terrain 512², 80 × 60 m texels, 32 directions, to the edge",
        &dir,
        &format!(
            r#"Horizon(id: "t", input: "{}", texel_size: (80, 60), height_scale: 1500, directions: 32, edge: Clamp)"#,
            sample.display()
        ),
    );
    rows(&sample);
    println!();
    let _ = std::fs::remove_dir_all(&dir);
}
