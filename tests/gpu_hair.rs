//! Hair strips and deep opacity maps on the GPU against their CPU reference.

use hikage_runtime::wgpu;

use crate::util::gpu;

/// Deep opacity maps of a few strands on the GPU against the CPU reference of the same
/// accumulation: the nearest depth and all four cumulative layers per texel, for both sets.
#[test]
fn hair_opacity_maps_match_the_cpu_accumulation() {
    use hikage_bake::strands::Strands;
    use hikage_bake::strands::strips::{StripSets, build};
    use hikage_runtime::glam::Vec3;
    use hikage_runtime::hair::{HairLight, HairSet, StripArrays, accumulate_cpu};
    use hikage_scenes::hair_scene::{GpuStrips, render_opacity_maps};

    let Some(g) = gpu("hair_opacity_maps_match_the_cpu_accumulation") else { return };
    // Three straight strands along x at different heights, overlapping seen from above, a
    // fourth along z crossing them, and a curved one.
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
        color: None,
        default_thickness: 0.05,
        default_transparency: 0.6,
        default_color: [0.5; 3],
    };
    let sets = StripSets { shading: (0.05, 0.4), opacity: (0.23, 0.09), taper: 0.0 };
    let (mesh, lo, hi) = build(&s, &sets);
    let arrays = StripArrays {
        position: mesh.read_f32("position").unwrap().chunks_exact(3).map(Vec3::from_slice).collect(),
        side: mesh.read_f32("side").unwrap(),
        tangent: mesh.read_f32("tangent").unwrap().chunks_exact(3).map(Vec3::from_slice).collect(),
        width: mesh.read_f32("width").unwrap().chunks_exact(2).map(|c| [c[0], c[1]]).collect(),
        opacity: mesh.read_f32("opacity").unwrap().chunks_exact(2).map(|c| [c[0], c[1]]).collect(),
        indices: mesh.read_indices().unwrap(),
    };
    let buffer =
        g.buffer(mesh.bytes.len() as u64, wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::INDEX, Some(&mesh.bytes));
    let strips = GpuStrips { buffer: &buffer, desc: &mesh.desc };
    let light = HairLight::for_bounds(Vec3::from(lo), Vec3::from(hi), Vec3::new(0.15, 1.0, 0.1));
    let resolution = 96;
    for set in [HairSet::Shading, HairSet::Opacity] {
        let maps = render_opacity_maps(&g, &strips, &light, set, resolution).unwrap();
        let (gpu_depth, gpu_layers) = maps.read(&g);
        let (cpu_depth, cpu_layers) = accumulate_cpu(&arrays, &light, set, resolution);
        let n = (resolution * resolution) as usize;
        let (mut covered, mut depth_ok, mut layers_ok) = (0, 0, 0);
        for i in 0..n {
            covered += (cpu_depth[i] < 1.0) as usize;
            depth_ok += ((gpu_depth[i] - cpu_depth[i]).abs() < 1e-4) as usize;
            // Half-float sums: a few thousandths.
            layers_ok += (0..4).all(|k| (gpu_layers[i][k] - cpu_layers[i][k]).abs() < 5e-3) as usize;
        }
        eprintln!(
            "{set:?}: {covered} texels covered; depth equal on {:.2}%, layers on {:.2}%",
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
}
