//! Hair strips and deep opacity maps on the GPU, through `HairRenderer`, against their CPU
//! reference: the light passes (depth map and layers), and the camera pass — Kajiya-Kay
//! shading, the maps' lookup, the order-independent blend and the opaque draw.

use hikage_bake::strands::Strands;
use hikage_bake::strands::strips::{StripSets, build};
use hikage_bundle::{BundleWriter, Settings, StrandsSettings, WriteMode};
use hikage_runtime::glam::Vec3;
use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::look_at_mat4;
use hikage_runtime::hair::reference::{StripArrays, accumulate_cpu};
use hikage_runtime::hair::{HairFrame, HairLight, HairOptions, HairRenderer, HairSet, LayerRule, Lookup};
use hikage_runtime::{CpuBundle, GpuBundle, wgpu};
use hikage_scenes::hair_scene::{
    Composite, HairBlend, camera_reference, read_opacity_maps, render_frame, srgb_to_linear,
};
use hikage_scenes::headless::{COLOR_FORMAT, DEPTH_FORMAT};

use crate::util::{Dir, gpu};

/// Three straight strands along x at different heights, overlapping seen from above, a fourth
/// along z crossing them, and a curved one; as a bundle holding their strips.
fn strands_bundle(name: &str) -> (Dir, StripArrays) {
    let mut points = Vec::new();
    let mut segments = Vec::new();
    for (k, (y, z)) in [(0.0f32, 0.0f32), (0.37, 0.113), (0.81, -0.071)].iter().enumerate() {
        for i in 0..6 {
            points.push([-1.0 + 0.4 * i as f32 + 0.013 * k as f32, *y, *z]);
        }
        segments.push(5u16);
    }
    for i in 0..5 {
        points.push([0.217, 0.55, -0.9 + 0.45 * i as f32]);
    }
    segments.push(4);
    for i in 0..8 {
        let a = i as f32 * 0.35;
        points.push([0.6 * a.cos() - 0.1, 0.2 + 0.05 * i as f32, 0.6 * a.sin()]);
    }
    segments.push(7);
    let s = Strands {
        segments,
        points,
        thickness: None,
        transparency: None,
        color: Some((0..32).map(|i| [0.2 + 0.02 * i as f32, 0.4, 0.7 - 0.015 * i as f32]).collect()),
        default_thickness: 0.05,
        default_transparency: 0.6,
        default_color: [0.5; 3],
    };
    let sets = StripSets { shading: (0.05, 0.4), opacity: (0.23, 0.09), taper: 0.0 };
    let (mesh, lo, hi) = build(&s, &sets);
    let settings = StrandsSettings {
        strands: 5,
        points: 32,
        shading: sets.shading,
        opacity: sets.opacity,
        taper: 0.0,
        auto_resolution: None,
        bounds_min: lo,
        bounds_max: hi,
    };
    let dir = Dir::new(name);
    let mut writer = BundleWriter::open(&dir.path("bundle"), WriteMode::Replace).unwrap();
    writer.put_mesh("s.strips", Settings::Strands(settings), "test", &mesh).unwrap();
    writer.commit().unwrap();
    (dir, StripArrays::from_mesh(&mesh).unwrap())
}

/// Deep opacity maps of a few strands on the GPU against the CPU reference of the same
/// accumulation: the nearest depth and all four cumulative layers per texel, for both sets and
/// both layer rules (the per-texel step is computed in the shader).
#[test]
fn hair_opacity_maps_match_the_cpu_accumulation() {
    let (dir, arrays) = strands_bundle("gpu_hair_maps");
    let cpu = CpuBundle::read(&dir.path("bundle")).unwrap();
    let Some(g) = gpu("hair_opacity_maps_match_the_cpu_accumulation") else { return };
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let resolution = 96;
    let options = HairOptions { resolution, ..HairOptions::new(COLOR_FORMAT, (8, 8)) };
    let renderer = HairRenderer::new(&g.device, &g.queue, &gb, "s.strips", &options).unwrap();
    let mut by_rule = Vec::new();
    for (set, rule) in
        [HairSet::Shading, HairSet::Opacity].into_iter().flat_map(|s| [(s, LayerRule::Box), (s, LayerRule::PerTexel)])
    {
        let light = HairLight { rule, ..renderer.light(Vec3::new(0.15, 1.0, 0.1)) };
        renderer.update(&g.queue, &HairFrame { set, ..HairFrame::new(Default::default(), Vec3::Z, light) });
        let mut encoder = g.device.create_command_encoder(&Default::default());
        renderer.render_opacity_maps(&mut encoder);
        g.queue.submit([encoder.finish()]);
        let (gpu_depth, gpu_layers) = read_opacity_maps(&g, &renderer);
        let (cpu_depth, cpu_layers) = accumulate_cpu(&arrays, &light, set, resolution);
        let n = (resolution * resolution) as usize;
        let (mut covered, mut depth_ok, mut layers_ok) = (0, 0, 0);
        for i in 0..n {
            covered += (cpu_depth[i] < 1.0) as usize;
            depth_ok += ((gpu_depth[i] - cpu_depth[i]).abs() < 1e-4) as usize;
            // Half-float sums: a few thousandths.
            layers_ok += (0..4).all(|k| (gpu_layers[i][k] - cpu_layers[i][k]).abs() < 5e-3) as usize;
        }
        by_rule.push(cpu_layers.clone());
        eprintln!(
            "{set:?} {rule:?}: {covered} texels covered; depth equal on {:.2}%, layers on {:.2}%",
            100.0 * depth_ok as f64 / n as f64,
            100.0 * layers_ok as f64 / n as f64
        );
        assert!(covered > 300, "the strands should cover part of the map");
        // Texel centres exactly on a shared triangle edge may be drawn once on the GPU and
        // twice by the inclusive CPU test: allow 1%.
        assert!(depth_ok as f64 >= 0.99 * n as f64 && layers_ok as f64 >= 0.99 * n as f64);
        // Several layers differ somewhere: the strands overlap in depth.
        assert!(cpu_layers.iter().any(|l| l[0] > 0.0 && l[3] > l[0] + 1e-3));
    }
    // The rules place the boundaries differently, so the test tells them apart.
    assert!(by_rule[0] != by_rule[1] && by_rule[2] != by_rule[3]);
}

/// The camera pass against its CPU reference on the same opacity maps (read back): Kajiya-Kay
/// shading, the maps' lookup (nearest and bilinear) and the weighted blended order-independent
/// composite (and the opaque draw) over black, per pixel.
#[test]
fn hair_camera_pass_matches_the_cpu_composite() {
    let (dir, arrays) = strands_bundle("gpu_hair_camera");
    let cpu = CpuBundle::read(&dir.path("bundle")).unwrap();
    let Some(g) = gpu("hair_camera_pass_matches_the_cpu_composite") else { return };
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let size = (128u32, 96u32);
    let mut options = HairOptions { resolution: 128, ..HairOptions::new(COLOR_FORMAT, size) };
    options.draw.depth_format = Some(DEPTH_FORMAT);
    let renderer = HairRenderer::new(&g.device, &g.queue, &gb, "s.strips", &options).unwrap();
    let light = renderer.light(Vec3::new(0.3, 1.0, 0.4));
    let eye = Vec3::new(0.2, 1.2, 3.0);
    let camera = directx::perspective(45f32.to_radians(), size.0 as f32 / size.1 as f32, 0.5, 10.0)
        * look_at_mat4(eye, Vec3::new(0.0, 0.3, 0.0), Vec3::Y);
    let cases = [
        (HairBlend::OrderIndependent, Composite::OrderIndependent, Lookup::Nearest),
        (HairBlend::Opaque, Composite::Opaque, Lookup::Nearest),
        (HairBlend::OrderIndependent, Composite::OrderIndependent, Lookup::Bilinear),
    ];
    for (blend, how, lookup) in cases {
        let frame =
            HairFrame { ambient: Vec3::splat(0.2), specular: 0.5, lookup, ..HairFrame::new(camera, eye, light) };
        renderer.update(&g.queue, &frame);
        let uniform = renderer.uniform(&frame);
        let image = render_frame(&g, &renderer, None, blend, size, wgpu::Color::BLACK);
        let maps = read_opacity_maps(&g, &renderer);
        let reference = camera_reference(&arrays, &uniform, &light, &maps, camera, eye, size, how);
        let (mut covered, mut close, mut lit) = (0, 0, 0.0f32);
        for (i, r) in reference.iter().enumerate() {
            if r[3] <= 0.0 {
                continue;
            }
            covered += 1;
            let got = [0, 1, 2].map(|k| srgb_to_linear(image[4 * i + k]));
            // The target is 8-bit: what the CPU gives above 1 is clamped there.
            close += (0..3).all(|k| (got[k] - r[k].min(1.0)).abs() <= 0.02 + 0.02 * r[k]) as u32;
            lit += r[0] + r[1] + r[2];
        }
        eprintln!(
            "{blend:?} {lookup:?}: {covered} pixels with hair, {:.2}% within 2% of the CPU",
            100.0 * close as f64 / covered as f64
        );
        assert!(covered > 500, "the strands should cover part of the image");
        assert!(lit / covered as f32 > 0.1, "lit hair");
        assert!(close as f64 >= 0.97 * covered as f64, "{blend:?}: {close} of {covered}");
    }
}

/// The reference ground shadow of the hair measurements (the shading set's opacity maps and the
/// ground both at a multiple of the test resolution, box-filtered down) converges: on the
/// sample head at a 64² test resolution, going from 8× to 16× changes it by less than 0.05 RMS
/// and 0.25 at any pixel, under a fifth of what separates the plain 1× maps from it.
#[test]
fn hair_reference_shadow_converges() {
    use hikage_scenes::hair_scene::{reference_shadow, shadow_errors};

    let dir = crate::util::shared_bundle(
        "gpu_hair_reference",
        r#"(output: "bundle", jobs: [Strands(id: "head", input: "data/head.hair")])"#,
    );
    let cpu = CpuBundle::read(&dir).unwrap();
    let Some(g) = gpu("hair_reference_shadow_converges") else { return };
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let settings = cpu.asset("head.strips").unwrap().asset.settings.strands().unwrap().clone();
    let (lo, hi) = (Vec3::from(settings.bounds_min), Vec3::from(settings.bounds_max));
    let to_light = Vec3::new(0.45, 1.0, 0.3).normalize();
    let y = lo.y - 3.0;
    let centre = Vec3::new(0.0, y, 0.0) - Vec3::new(to_light.x, 0.0, to_light.z) * ((hi.y - y) * 0.5 / to_light.y);
    let half = 45.0;
    let corners =
        [(-half, -half), (-half, half), (half, half), (half, -half)].map(|(x, z)| centre + Vec3::new(x, 0.0, z));
    let top = directx::orthographic(-half, half, -half, half, 0.0, 200.0)
        * hikage_runtime::glam::camera::rh::view::look_to_mat4(
            centre + Vec3::new(0.0, 100.0, 0.0),
            Vec3::NEG_Y,
            Vec3::NEG_Z,
        );
    let size = (64u32, 64u32);
    let at = |factor| reference_shadow(&g, &gb, "head.strips", to_light, corners, top, (64, size), factor).unwrap();
    let (plain, eight, sixteen) = (at(1), at(8), at(16));
    let (rms, max, _) = shadow_errors(&eight, &sixteen);
    let (plain_rms, _, _) = shadow_errors(&plain, &sixteen);
    eprintln!("8× vs 16×: RMS {rms:.4}, max {max:.3}; 1× vs 16×: RMS {plain_rms:.4}");
    assert!(sixteen.iter().filter(|&&v| v < 0.98).count() > 200, "the shadow should be in view");
    assert!(rms < 0.05 && max < 0.25, "8× vs 16×: RMS {rms}, max {max}");
    assert!(plain_rms > 5.0 * rms, "1× maps {plain_rms} should be far from the reference ({rms})");
}
