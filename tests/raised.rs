//! Far terrain shadows on what stands on the terrain: the sun visibility of a point above the
//! ground from the baked horizons (`horizon_raised_sun_visible`) against an exact march from the
//! raised point over the heights (`hikage_devkit::brute_force`), on a rough terrain the test
//! generates.

use hikage_runtime::CpuBundle;
use hikage_runtime::glam::{Vec2, Vec3};
use hikage_runtime::horizon::reference::{HorizonMap, horizon_raised_sun_visible, horizon_sun_visible};

use hikage_devkit::brute_force::raised_shadow_height;

use crate::util::Dir;

/// Map side (texels), texel size and reach (m).
const N: usize = 128;
const TEXEL: f32 = 30.0;
const REACH: f32 = 2400.0;

/// Points 2 to 100 m up agree with the march as often as the ground's own test does, within a
/// point, and a raised point is never much more often lit wrongly than the ground; the ground's
/// horizon alone, which darkens raised points, falls far behind at 100 m.
#[test]
fn raised_points_agree_with_an_exact_march_as_the_ground_does() {
    let dir = Dir::new("raised");
    let samples = hikage_devkit::synth::terrain(N as u32);
    dir.write("dem.r32", samples.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>());
    let heights: Vec<f32> = samples.iter().map(|v| v * 900.0).collect();
    dir.write(
        "pipeline.ron",
        format!(
            r#"(output: "bundle", jobs: [Horizon(id: "t", input: "dem.r32", texel_size: ({TEXEL}, {TEXEL}),
               height_scale: 900, directions: 24, edge: Clamp, max_distance: {REACH})])"#
        ),
    );
    dir.run(&["bake"]);
    let cpu = CpuBundle::read_prefix(&dir.path("bundle"), "t.").unwrap();
    let asset = cpu.asset("t.horizon").unwrap();
    let map = HorizonMap::new(asset.texture().unwrap(), asset.asset.settings.horizon().unwrap(), true).unwrap();
    let texel = Vec2::splat(TEXEL);
    let points: Vec<(usize, usize)> = (0..1500).map(|k| ((k * 37 + 11) % N, (k * 53 + k / N + 5) % N)).collect();
    let suns = [(3f32, 20f32), (8.0, 130.0), (15.0, 250.0), (25.0, 310.0)];
    let mut rates = Vec::new();
    for h in [0.0f32, 2.0, 10.0, 30.0, 100.0] {
        let (mut walk, mut ground, mut leaks, mut total) = (0usize, 0usize, 0usize, 0usize);
        for &(e, a) in &suns {
            let (e, a) = (e.to_radians(), a.to_radians());
            let sun = Vec3::new(e.cos() * a.cos(), e.cos() * a.sin(), e.sin());
            for &(i, j) in &points {
                let lit = h > raised_shadow_height(&heights, (N, N), (TEXEL, TEXEL), (i, j), (e, a), REACH);
                let uv = Vec2::new((i as f32 + 0.5) / N as f32, (j as f32 + 0.5) / N as f32);
                let raised = horizon_raised_sun_visible(&map, uv, sun, texel, h, REACH, 0.0) > 0.5;
                let on_ground = horizon_sun_visible(&map, uv, sun, texel, 0.0) > 0.5;
                walk += (raised == lit) as usize;
                ground += (on_ground == lit) as usize;
                leaks += (raised && !lit) as usize;
                total += 1;
            }
        }
        let share = |n: usize| n as f64 / total as f64;
        eprintln!(
            "h {h} m: the walk agrees on {:.2}%, the ground's horizon on {:.2}%; {:.2}% lit wrongly",
            100.0 * share(walk),
            100.0 * share(ground),
            100.0 * share(leaks)
        );
        rates.push((h, share(walk), share(ground), share(leaks)));
    }
    let (_, on_ground, _, ground_leaks) = rates[0];
    assert!(on_ground > 0.95, "the ground's own test agrees on {on_ground}");
    for &(h, walk, ground, leaks) in &rates {
        assert!(walk >= on_ground - 0.01, "{h} m: {walk} against the ground's {on_ground}");
        assert!(leaks <= ground_leaks + 0.005, "{h} m: {leaks} lit wrongly");
        if h == 100.0 {
            assert!(walk > ground + 0.05, "100 m: the walk {walk}, the ground's horizon {ground}");
        }
    }
}
