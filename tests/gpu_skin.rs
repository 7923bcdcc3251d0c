//! Hair bound to a skinned scalp: `hikage strands --scalp` on a generated character (a head on a
//! neck, two joints, its GLB written by the devkit), then `HairSkin` posing the strands on the GPU
//! over the character's animation loop, against the devkit's own skinning of where each root was
//! placed and against the same strands posed on the CPU and baked static.

use hikage_bake::strands::Strands;
use hikage_bundle::{Scalp, StrandPoint};
use hikage_devkit::synth::{self, Character};
use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::look_at_mat4;
use hikage_runtime::glam::{Mat4, Vec3};
use hikage_runtime::hair::reference::{hair_skin, skin_polylines};
use hikage_runtime::hair::{HairFrame, HairLight, HairOptions, HairRenderer, HairSkin};
use hikage_runtime::{CpuBundle, GpuBundle, wgpu};
use hikage_scenes::hair_scene::{Ground, HairBlend, render_frame};
use hikage_scenes::headless::{COLOR_FORMAT, DEPTH_FORMAT, Headless};

use crate::util::{Dir, gpu};

/// Poses of the loop the tests check: eight evenly spaced, through both turns and all four nods.
const POSES: usize = 8;

/// The character, its strands baked with `--scalp` into `b`, and the bundle read back.
fn bound_character(name: &str) -> (Dir, Character, CpuBundle) {
    let character = synth::character(1500, 12, 7);
    let dir = Dir::new(name);
    dir.write("character.glb", &character.glb);
    dir.write("head.hair", hikage_bake::strands::cyhair::encode(&character.hair, "skinned character"));
    dir.run(&["strands", "head.hair", "--out", "b", "--scalp", "character.glb"]);
    dir.run(&["validate", "b"]);
    let cpu = CpuBundle::read(&dir.path("b")).unwrap();
    (dir, character, cpu)
}

/// Where the devkit's skin puts a rest-pose point of triangle `t` with barycentric weights `w`:
/// each corner skinned by its two joints, then blended.
fn skinned_surface_point(c: &Character, (t, w): (u32, [f32; 3]), joints: &[Mat4; 2]) -> Vec3 {
    c.triangles[t as usize].iter().zip(w).fold(Vec3::ZERO, |acc, (&v, wv)| {
        let p = Vec3::from(c.positions[v as usize]);
        let [wn, wh] = c.weights[v as usize];
        acc + wv * (wn * joints[0].transform_point3(p) + wh * joints[1].transform_point3(p))
    })
}

/// The records of the strands as the GPU posed them for `joints`.
fn posed_on_gpu(g: &Headless, skin: &HairSkin, joints: &[Mat4], max_width: f32) -> Vec<StrandPoint> {
    skin.update(&g.queue, joints).unwrap();
    let mut encoder = g.device.create_command_encoder(&Default::default());
    skin.record(&mut encoder);
    g.queue.submit([encoder.finish()]);
    let bytes = g.read_buffer(skin.posed_records());
    bytes
        .chunks_exact(hikage_bundle::STRANDS_RECORD_BYTES as usize)
        .take(skin.points() as usize)
        .map(|r| StrandPoint::decode(r, max_width))
        .collect()
}

/// Each strand's length (sum of its segments), by strand id.
fn lengths(points: &[StrandPoint]) -> Vec<f64> {
    let strands = points.iter().map(|p| p.strand_id as usize + 1).max().unwrap_or(0);
    let mut out = vec![0.0f64; strands];
    for pair in points.windows(2).filter(|w| w[0].strand_id == w[1].strand_id && w[1].index == w[0].index + 1) {
        out[pair[0].strand_id as usize] +=
            (Vec3::from(pair[1].position) - Vec3::from(pair[0].position)).length() as f64;
    }
    out
}

/// Over the animation loop, on the GPU: every root stays within 0.5 px (in a 512² view of the
/// head) of the point of the scalp it was placed on, as the devkit's own skinning moves that
/// point; every strand keeps its length within 0.1%; and every record equals the CPU reference
/// of the pass. The binding takes 8 bytes a strand.
#[test]
fn skinned_hair_roots_stay_on_the_scalp_over_the_loop() {
    let (_dir, character, cpu) = bound_character("gpu_skin_roots");
    let binding = cpu.asset("head.binding").unwrap();
    let scalp_asset = cpu.asset("head.scalp").unwrap();
    let strips = cpu.asset("head.strips").unwrap();
    let settings = strips.asset.settings.strands().unwrap().clone();
    let strands = settings.strands as usize;
    let binding_mesh = binding.mesh().unwrap();
    assert_eq!(binding_mesh.desc.buffer_bytes() as usize, 8 * strands, "8 bytes a strand");
    let scalp = Scalp::read(scalp_asset.mesh().unwrap()).unwrap();
    eprintln!(
        "binding: {} B for {strands} strands; scalp: {} of {} triangles, {} B",
        binding_mesh.desc.buffer_bytes(),
        scalp.triangles.len(),
        character.triangles.len(),
        scalp_asset.mesh().unwrap().desc.buffer_bytes()
    );
    let bindings = hikage_bundle::binding::read_binding(binding_mesh).unwrap();
    let rest = hikage_bundle::read_strand_points(strips.mesh().unwrap(), &settings).unwrap();
    let rest_lengths = lengths(&rest);
    let Some(g) = gpu("skinned_hair_roots_stay_on_the_scalp_over_the_loop") else { return };
    let gpu_bundle = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let skin = HairSkin::new(&g.device, &g.queue, &gpu_bundle, binding, scalp_asset).unwrap();
    assert_eq!(skin.joint_names(), ["neck", "head"]);
    let size = 512.0;
    let eye = Vec3::new(20.0, 22.0, 55.0);
    let camera = directx::perspective(45f32.to_radians(), 1.0, 1.0, 200.0)
        * look_at_mat4(eye, Vec3::new(0.0, 10.0, 0.0), Vec3::Y);
    let pixel = |p: Vec3| {
        let c = camera.project_point3(p);
        Vec3::new(c.x, c.y, 0.0) * 0.5 * size
    };
    let (mut worst_root, mut worst_length, mut worst_record) = (0.0f32, 0.0f64, 0.0f32);
    let mut looseness = (f32::INFINITY, 0.0f32);
    for k in 0..POSES {
        let joints = synth::pose(k as f32 / POSES as f32);
        let posed = posed_on_gpu(&g, &skin, &joints, settings.max_width);
        // The skin's box holds every posed point; how much larger it is than their own box.
        let (lo, hi) = skin.bounds(&joints);
        let (a, b) = posed.iter().fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(a, b), p| {
            (a.min(Vec3::from(p.position)), b.max(Vec3::from(p.position)))
        });
        assert!(lo.cmple(a).all() && b.cmple(hi).all(), "pose {k}: {a}..{b} outside the skin's box {lo}..{hi}");
        let ratio = (hi - lo) / (b - a);
        looseness = (looseness.0.min(ratio.min_element()), looseness.1.max(ratio.max_element()));
        let reference = hair_skin(&rest, &bindings, &scalp, &joints);
        for (p, r) in posed.iter().zip(&reference) {
            worst_record = worst_record.max((Vec3::from(p.position) - Vec3::from(r.position)).length());
            assert_eq!((p.strand_id, p.index, p.width, p.color), (r.strand_id, r.index, r.width, r.color));
            assert!(Vec3::from(p.tangent).dot(Vec3::from(r.tangent)) > 0.9999, "{p:?} against {r:?}");
        }
        for root in posed.iter().filter(|p| p.index == 0) {
            let placed = skinned_surface_point(&character, character.roots[root.strand_id as usize], &joints);
            worst_root = worst_root.max((pixel(Vec3::from(root.position)) - pixel(placed)).length());
        }
        for (now, then) in lengths(&posed).iter().zip(&rest_lengths) {
            worst_length = worst_length.max((now / then - 1.0).abs());
        }
    }
    eprintln!("the skin's box is {:.2}–{:.2} times the posed hair's a side", looseness.0, looseness.1);
    eprintln!(
        "over {POSES} poses: roots within {worst_root:.4} px of their scalp points, lengths within {:.5}%, records within {worst_record:.2e} of the CPU reference",
        100.0 * worst_length
    );
    assert!(worst_root <= 0.5, "a root drifted {worst_root} px");
    assert!(worst_length <= 1e-3, "a strand changed its length by {}", worst_length);
    assert!(worst_record <= 1e-3, "the GPU's records differ from the CPU reference by {worst_record}");
    // The skin refuses joint matrices that are not its own.
    assert!(skin.update(&g.queue, &[Mat4::IDENTITY]).unwrap_err().to_string().contains("2 joints"));
}

/// Skinned hair drawn in two poses — the hair, its shadow on a ground and on itself, blended and
/// opaque — matches the same strands posed on the CPU and baked static, drawn with the same light
/// and box: within 1/255 on at least 99.9% of the pixels.
#[test]
fn skinned_hair_draws_as_the_same_hair_baked_posed() {
    let (dir, character, cpu) = bound_character("gpu_skin_draw");
    let strips = cpu.asset("head.strips").unwrap();
    let settings = strips.asset.settings.strands().unwrap().clone();
    let bindings = hikage_bundle::binding::read_binding(cpu.asset("head.binding").unwrap().mesh().unwrap()).unwrap();
    let scalp = Scalp::read(cpu.asset("head.scalp").unwrap().mesh().unwrap()).unwrap();
    let Some(g) = gpu("skinned_hair_draws_as_the_same_hair_baked_posed") else { return };
    let size = (200u32, 160u32);
    let mut options = HairOptions { resolution: 128, ..HairOptions::new(COLOR_FORMAT, size) };
    options.draw.depth_format = Some(DEPTH_FORMAT);
    let gpu_bundle = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let skin = HairSkin::new(
        &g.device,
        &g.queue,
        &gpu_bundle,
        cpu.asset("head.binding").unwrap(),
        cpu.asset("head.scalp").unwrap(),
    )
    .unwrap();
    let mut skinned = HairRenderer::new(&g.device, &g.queue, &gpu_bundle, "head.strips", &options).unwrap();
    skinned.follow(&skin).unwrap();
    let eye = Vec3::new(25.0, 30.0, 60.0);
    let centre = Vec3::new(0.0, 8.0, 0.0);
    let camera = directx::perspective(45f32.to_radians(), size.0 as f32 / size.1 as f32, 1.0, 300.0)
        * look_at_mat4(eye, centre, Vec3::Y);
    let corners = [(-40.0, -40.0), (-40.0, 40.0), (40.0, 40.0), (40.0, -40.0)].map(|(x, z)| Vec3::new(x, -12.0, z));
    for t in [0.2f32, 0.65] {
        let joints = synth::pose(t);
        // The same strands posed on the CPU (each strand moved rigidly, as the reference poses
        // records) and baked static.
        let hair = &character.hair;
        let points = skin_polylines(&hair.segments, &hair.points, &bindings, &scalp, &joints);
        let posed = Strands { points, ..hair.clone() };
        let tag = (t * 100.0) as u32;
        dir.write(&format!("posed_{tag}.hair"), hikage_bake::strands::cyhair::encode(&posed, "posed"));
        let out = format!("static_{tag}");
        dir.run(&["strands", &format!("posed_{tag}.hair"), "--out", &out]);
        let mut static_cpu = CpuBundle::read(&dir.path(&out)).unwrap();
        // The blend's density is the hair's at rest, as the skinned renderer's asset has it.
        for a in &mut static_cpu.assets {
            if let hikage_bundle::Settings::Strands(s) = &mut a.asset.settings {
                (s.bounds_min, s.bounds_max) = (settings.bounds_min, settings.bounds_max);
            }
        }
        let static_gpu = GpuBundle::upload(&g.device, &g.queue, &static_cpu).unwrap();
        let baked =
            HairRenderer::new(&g.device, &g.queue, &static_gpu, &format!("posed_{tag}.strips"), &options).unwrap();
        let bounds = skin.update(&g.queue, &joints).unwrap();
        let mut encoder = g.device.create_command_encoder(&Default::default());
        skin.record(&mut encoder);
        g.queue.submit([encoder.finish()]);
        let light = HairLight::for_bounds(bounds.0, bounds.1, Vec3::new(0.4, 1.0, 0.3));
        let frame = HairFrame { bounds: Some(bounds), ambient: Vec3::splat(0.2), ..HairFrame::new(camera, eye, light) };
        for blend in [HairBlend::OrderIndependent, HairBlend::Opaque] {
            let images: Vec<Vec<u8>> = [&skinned, &baked]
                .into_iter()
                .map(|renderer| {
                    renderer.update(&g.queue, &frame);
                    let ground = Ground::new(&g, renderer, corners);
                    render_frame(&g, renderer, Some((&ground, camera)), blend, size, wgpu::Color::BLACK)
                })
                .collect();
            let pixels = (size.0 * size.1) as usize;
            let agree = (0..pixels)
                .filter(|&i| (0..3).all(|k| images[0][4 * i + k].abs_diff(images[1][4 * i + k]) <= 1))
                .count();
            let drawn = (0..pixels).filter(|&i| images[1][4 * i..4 * i + 3] != [0, 0, 0]).count();
            eprintln!("pose {t}, {blend:?}: {agree} of {pixels} pixels within 1/255 ({drawn} drawn)");
            assert!(drawn > pixels / 4, "the hair and the ground fill part of the image");
            assert!(agree as f64 >= 0.999 * pixels as f64, "pose {t}, {blend:?}: {agree} of {pixels}");
        }
    }
}
