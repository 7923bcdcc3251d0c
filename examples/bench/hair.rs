//! Hair strips: strands per second for the 10,000-strand sample and a 1,000,000-strand set,
//! bytes per point against the `.hair` input, peak memory against the output's size, the
//! automatic opacity set against the plain bake and against scoring each candidate alone, and
//! the camera frame on this adapter: strips at their own width against strips of at least a
//! pixel, and the levels of detail against every strand.

use hikage_bake::strands::auto;
use hikage_bake::strands::strips::{self, StripSets};
use hikage_devkit::synth;

use crate::best_of;

/// The hair rows (issues 5 and 29).
pub fn run() {
    let threads = rayon::current_num_threads();
    println!("Hair strips ({threads} threads; one 32-byte record per point)\n");
    println!("| input | build | strands/s | baseline | ratio | peak memory | output |");
    println!("|---|---|---|---|---|---|---|");
    let bytes = std::fs::read("data/head.hair").expect("run from the repository root (data/ is read)");
    let (t_read, s) =
        best_of(5, || hikage_bake::strands::cyhair::decode(&bytes, &Default::default()).expect("the sample is valid"));
    let sets = StripSets::from_source(&s);
    let (t, strips) = best_of(5, || strips::build(&s, &sets));
    println!(
        "| data/head.hair: 10,000 × 22 = 220,000 points | {:.1} ms (+ {:.1} ms reading) | {:.2e} | target 50 ms | {:.2}× of the budget | — | {:.1} MiB |",
        t * 1e3,
        t_read * 1e3,
        s.segments.len() as f64 / t,
        (t + t_read) / 0.050,
        strips.mesh.bytes.len() as f64 / (1 << 20) as f64
    );
    let per_point = strips.mesh.bytes.len() as f64 / s.points.len() as f64;
    println!(
        "| bytes per point | {per_point:.1} B | — | the .hair file: {:.1} B | {:.2}× | — | target ≤ 32 B (the expanded strips of format 1.4: 142 B) |",
        bytes.len() as f64 / s.points.len() as f64,
        per_point / (bytes.len() as f64 / s.points.len() as f64),
    );
    drop(strips);
    let (t_auto, _) = best_of(3, || auto::choose(&s, &sets, 256));
    let (t_alone, _) = best_of(1, || score_each_alone(&s, &sets, 256));
    println!(
        "| auto opacity set for a 256² map, same input | {:.0} ms | — | plain: {:.0} ms | {:.1}× the plain build (target ≤ 10×) | — | scoring each candidate alone: {:.0} ms ({:.2}×) |",
        t_auto * 1e3,
        (t + t_read) * 1e3,
        (t_auto + t_read + t) / (t + t_read),
        t_alone * 1e3,
        t_auto / t_alone
    );
    drop(s);

    let big = synth::hair(1_000_000, 22, 99);
    let input = big.points.len() * 12 + big.points.len() * 8;
    let sets = StripSets::from_source(&big);
    let mut peak = f64::NAN;
    let (t, out) = best_of(2, || {
        let fresh = crate::reset_peak_rss();
        let before = crate::peak_rss_mib().unwrap_or(f64::NAN);
        let r = strips::build(&big, &sets);
        if fresh {
            peak = crate::peak_rss_mib().unwrap_or(f64::NAN) - before;
        }
        r
    });
    let out_mib = out.mesh.bytes.len() as f64 / (1 << 20) as f64;
    println!(
        "| generated: 1,000,000 × 22 = 22,000,000 points | {t:.2} s | {:.2e} | target 5 s | {:.2}× of the budget | +{peak:.0} MiB over the {:.0} MiB input (target ≤ 2× output) | {out_mib:.0} MiB |",
        big.segments.len() as f64 / t,
        t / 5.0,
        input as f64 / (1 << 20) as f64,
    );
    println!();
    drop(out);
    drop(big);
    camera_frames();
}

/// The choice before one walk scored every candidate: each candidate's shadow walked alone,
/// candidates in parallel.
fn score_each_alone(s: &hikage_bake::strands::Strands, base: &StripSets, resolution: u32) -> f32 {
    use rayon::prelude::*;
    let views: Vec<auto::LightView> =
        auto::directions()[..6].par_iter().map(|&d| auto::LightView::new(s, d, resolution, base)).collect();
    let count = (auto::MAX_WIDTH_RATIO.log2() * 4.0).round() as i32;
    (0..=count)
        .into_par_iter()
        .map(|k| {
            let width = base.shading.0 * 2f32.powf(k as f32 / 4.0);
            let sets = StripSets { opacity: (width, auto::matching_alpha(base, width)), ..*base };
            (views.iter().map(|v| v.squared_error(s, &sets).0).sum::<f64>(), width)
        })
        .collect::<Vec<_>>()
        .into_iter()
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map_or(0.0, |b| b.1)
}

/// Camera frames of the sample head at 512² on this adapter (opacity maps, hair, composite;
/// best of 3).
fn camera_frames() {
    use hikage_runtime::glam::Vec3;
    use hikage_runtime::hair::{BlendWeight, HairFrame, HairLod, Lod};
    use hikage_runtime::{CpuBundle, GpuBundle};
    use hikage_scenes::hair_view::{orbit_camera, render_view, renderers};
    let Ok(g) = hikage_scenes::headless::Headless::new() else {
        println!("(no GPU adapter: camera frames skipped)\n");
        return;
    };
    let dir = std::env::temp_dir().join(format!("hikage-bench-hair-{}", std::process::id()));
    let pipeline = dir.join("pipeline.ron");
    let head = std::fs::canonicalize("data/head.hair").expect("data/head.hair");
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    let text = format!(r#"(output: "bundle", jobs: [Strands(id: "head", input: "{}")])"#, head.display());
    std::fs::write(&pipeline, text).expect("writing the scratch pipeline");
    hikage_bake::run::run_pipeline(&pipeline, &Default::default()).expect("baking the sample head");
    let cpu = CpuBundle::read(&dir.join("bundle")).expect("reading the scratch bundle");
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).expect("uploading");
    let (one, _) = renderers(&g, &gb, "head.strips", 512, 1, 256).expect("a renderer");
    let s = one.settings();
    let (camera, eye) = orbit_camera(Vec3::from(s.bounds_min), Vec3::from(s.bounds_max), 0.0);
    let frame = |min_pixel_width: f32, level: u32| HairFrame {
        min_pixel_width,
        lod: HairLod { camera: Lod::Level(level), light: Lod::Level(0) },
        ..HairFrame::new(camera, eye, one.light(Vec3::new(0.45, 1.0, 0.3)))
    };
    let time = |f: &HairFrame| best_of(3, || render_view(&g, &one, f, 512, 1)).0;
    println!("Hair camera frames, sample head at 512² on {} (opacity maps 256², best of 3)\n", g.describe());
    println!("| frame | time | baseline | ratio |");
    println!("|---|---|---|---|");
    let own = time(&frame(0.0, 0));
    let filtered = time(&frame(1.0, 0));
    println!(
        "| strips ≥ 1 px, opacity compensated | {:.0} ms | own width: {:.0} ms | {:.2}× (target ≤ 2.5×) |",
        filtered * 1e3,
        own * 1e3,
        filtered / own
    );
    let by_depth =
        hikage_scenes::hair_view::renderer(&g, &gb, "head.strips", 512, 256, BlendWeight::Depth).expect("a renderer");
    let depth_weighted = best_of(3, || render_view(&g, &by_depth, &frame(1.0, 0), 512, 1)).0;
    println!(
        "| blend weighted by the camera's opacity layers (the default; ≥ 1 px) | {:.0} ms | weighted by depth: {:.0} ms | {:.2}× |",
        filtered * 1e3,
        depth_weighted * 1e3,
        filtered / depth_weighted
    );
    for level in 1..4 {
        let t = time(&frame(1.0, level));
        let strands = one.levels().get(level as usize).map_or(0, |l| l[0]);
        println!(
            "| level {level} ({strands} strands), ≥ 1 px | {:.0} ms | level 0: {:.0} ms | {:.2}× |",
            t * 1e3,
            filtered * 1e3,
            t / filtered
        );
    }
    println!();
    let _ = std::fs::remove_dir_all(&dir);
}

/// Skinned against static hair: the devkit's character with 20,000 strands of 16 points, its
/// frame at 512² (the skinning pass, opacity maps, hair, composite) against the same strands
/// drawn without the skin, and the skinning pass alone; best of 5, in one run.
pub fn skinned_frames() {
    use hikage_runtime::glam::Vec3;
    use hikage_runtime::hair::{HairFrame, HairLight, HairSkin};
    use hikage_runtime::{CpuBundle, GpuBundle, wgpu};
    use hikage_scenes::hair_view::{orbit_camera, render_view, renderers};
    let Ok(g) = hikage_scenes::headless::Headless::new() else {
        println!("(no GPU adapter: skinned frames skipped)\n");
        return;
    };
    let dir = std::env::temp_dir().join(format!("hikage-bench-skin-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    let (strands, points) = (20_000u32, 16u16);
    let character = hikage_devkit::synth::character(strands, points, 3);
    std::fs::write(dir.join("character.glb"), &character.glb).expect("writing the character");
    let hair = hikage_bake::strands::cyhair::encode(&character.hair, "bench character");
    std::fs::write(dir.join("head.hair"), hair).expect("writing the hair");
    let text = r#"(output: "bundle", jobs: [Strands(id: "head", input: "head.hair", scalp: Some("character.glb"))])"#;
    std::fs::write(dir.join("pipeline.ron"), text).expect("writing the scratch pipeline");
    hikage_bake::run::run_pipeline(&dir.join("pipeline.ron"), &Default::default()).expect("baking the character");
    let cpu = CpuBundle::read(&dir.join("bundle")).expect("reading the scratch bundle");
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).expect("uploading");
    let asset = |id: &str| cpu.asset(id).expect("baked above");
    let skin = HairSkin::new(&g.device, &g.queue, &gb, asset("head.binding"), asset("head.scalp")).expect("a skin");
    let (still, _) = renderers(&g, &gb, "head.strips", 512, 1, 256).expect("a renderer");
    let (mut skinned, _) = renderers(&g, &gb, "head.strips", 512, 1, 256).expect("a renderer");
    skinned.follow(&skin).expect("the skin poses these strands");
    let joints = hikage_devkit::synth::pose(0.3);
    let bounds = skin.update(&g.queue, &joints).expect("two joints");
    let (camera, eye) = orbit_camera(bounds.0, bounds.1, 20.0);
    let to_light = Vec3::new(0.45, 1.0, 0.3);
    let light = HairLight::for_bounds(bounds.0, bounds.1, to_light);
    // Both drawn in the same box, so only the skinning differs.
    let frame = HairFrame { bounds: Some(bounds), ..HairFrame::new(camera, eye, light) };
    let pose = || {
        let mut encoder = g.device.create_command_encoder(&Default::default());
        skin.record(&mut encoder);
        g.queue.submit([encoder.finish()]);
    };
    let still_time = best_of(5, || render_view(&g, &still, &frame, 512, 1)).0;
    let skinned_time = best_of(5, || {
        skin.update(&g.queue, &joints).expect("two joints");
        pose();
        render_view(&g, &skinned, &frame, 512, 1)
    })
    .0;
    let pass_time = best_of(5, || {
        pose();
        g.device.poll(wgpu::PollType::wait_indefinitely()).expect("device poll");
    })
    .0;
    let update_time = best_of(5, || skin.update(&g.queue, &joints).expect("two joints")).0;
    let records = skin.points();
    println!(
        "Skinned hair, the devkit's character ({strands} strands, {records} records, two joints) at 512² on {} (best of 5)\n",
        g.describe()
    );
    println!("| frame | time | baseline | ratio |");
    println!("|---|---|---|---|");
    println!(
        "| skinned: skin pass + opacity maps + hair + composite | {:.1} ms | static: {:.1} ms | {:.2}× |",
        skinned_time * 1e3,
        still_time * 1e3,
        skinned_time / still_time
    );
    println!(
        "| the skin pass alone | {:.2} ms | static frame: {:.1} ms | {:.3}× |",
        pass_time * 1e3,
        still_time * 1e3,
        pass_time / still_time
    );
    println!("| the skin's update (joints, CPU box) | {:.3} ms | — | — |", update_time * 1e3);
    println!();
    let _ = std::fs::remove_dir_all(&dir);
}
