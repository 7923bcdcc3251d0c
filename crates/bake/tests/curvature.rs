//! Curvature of analytic surfaces: a sphere (κ1 = κ2 = 1/r) and a cylinder (1/r, 0, the first
//! principal direction around it), plus the errors of bad meshes.

use std::path::Path;

use hikage_bake::curvature::{CurvatureError, compute};
use hikage_bake::mesh::obj;
use hikage_bake::synth;

#[test]
fn sphere_has_equal_principal_curvatures_of_one_over_r() {
    let r = 2.0;
    let mesh = obj::parse(&synth::uv_sphere_obj(r, 64, 32, 1.0), Path::new("sphere.obj")).unwrap();
    let c = compute(&mesh).unwrap();
    let mut worst: f64 = 0.0;
    for (v, vc) in c.iter().enumerate() {
        let p = mesh.positions[mesh.vertex_position[v] as usize];
        if p.y.abs() > 0.9 * r {
            continue; // the poles' fans are not a regular grid
        }
        worst = worst.max((vc.k1 - 1.0 / r).abs()).max((vc.k2 - 1.0 / r).abs());
        assert!((vc.normal - p / r).length() < 0.01, "normals point outward");
    }
    // A quadric fit over the 2-ring: within 2% on this 64×32 grid (cells up to 3:1 near ±0.9 r).
    assert!(worst < 0.02 / r, "worst curvature error {worst} for 1/r = {}", 1.0 / r);
}

#[test]
fn cylinder_has_one_over_r_around_and_zero_along() {
    let r = 3.0;
    let mesh = obj::parse(&synth::cylinder_obj(r, 10.0, 96, 24), Path::new("cylinder.obj")).unwrap();
    let c = compute(&mesh).unwrap();
    for (v, vc) in c.iter().enumerate() {
        let p = mesh.positions[mesh.vertex_position[v] as usize];
        if p.y < 1.0 || p.y > 9.0 {
            continue; // open ends have one-sided neighbourhoods
        }
        assert!((vc.k1 - 1.0 / r).abs() < 0.01 / r, "k1 {} at {p}", vc.k1);
        assert!(vc.k2.abs() < 0.01 / r, "k2 {} at {p}", vc.k2);
        // u runs around the cylinder: the first principal direction is ±u in the texture frame.
        assert!(vc.dir1_uv.x.abs() > 0.999 && vc.dir2_uv.y.abs() > 0.999, "{:?} {:?}", vc.dir1_uv, vc.dir2_uv);
    }
}

#[test]
fn bad_meshes_are_refused_with_place() {
    let no_uv = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let e = obj::parse(no_uv, Path::new("m.obj")).unwrap_err().to_string();
    assert!(e.contains("m.obj: line 4") && e.contains("texture coordinate"), "{e}");
    let out_of_range = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 4/1\n";
    let e = obj::parse(out_of_range, Path::new("m.obj")).unwrap_err().to_string();
    assert!(e.contains("line 5") && e.contains("vertex index 4 is out of range"), "{e}");
    let nan = "v 0 nan 0\n";
    assert!(obj::parse(nan, Path::new("m.obj")).unwrap_err().to_string().contains("line 1"));
    let degenerate = "v 0 0 0\nv 1 0 0\nv 2 0 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
    let mesh = obj::parse(degenerate, Path::new("m.obj")).unwrap();
    assert_eq!(compute(&mesh).unwrap_err(), CurvatureError::Degenerate { triangle: 0 });
    let flat_uv = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 2 0\nf 1/1 2/2 3/3\n";
    let mesh = obj::parse(flat_uv, Path::new("m.obj")).unwrap();
    assert_eq!(compute(&mesh).unwrap_err(), CurvatureError::DegenerateUv { triangle: 0 });
    assert!(obj::parse("# nothing\n", Path::new("m.obj")).is_err());
}
