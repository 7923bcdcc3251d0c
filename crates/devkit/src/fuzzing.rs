//! Entry points of the fuzz targets (`fuzz/`, cargo-fuzz) and of the test that replays their
//! regression corpus: one function per reader of untrusted input. Each takes arbitrary bytes,
//! runs the reader the way the CLI does, and discards the result; the property checked is that
//! none of them panics, overflows or allocates without bound. Readers that take a path get a
//! file in a per-process temporary directory.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use hikage_bundle::{Limits, Manifest};

/// A per-process scratch directory (`$TMPDIR/hikage-fuzz-<pid>`).
fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("hikage-fuzz-{}", std::process::id()));
        let _ = std::fs::create_dir_all(&dir);
        dir
    })
}

/// `bundle.ron` text → [`Manifest::parse`].
pub fn manifest(data: &[u8]) {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = Manifest::parse(text, Path::new("<fuzz>/bundle.ron"));
    }
}

/// A bundle directory whose `bundle.ron` is `data`, beside one valid 4×4 R8 KTX2 payload
/// `t.ktx2`: [`hikage_bundle::validate()`], then [`hikage_bundle::Bundle::open`] and every asset
/// read.
pub fn bundle(data: &[u8]) {
    let dir = scratch().join("bundle");
    let _ = std::fs::create_dir_all(&dir);
    static PAYLOAD: OnceLock<()> = OnceLock::new();
    PAYLOAD.get_or_init(|| {
        let hf = hikage_bake::Heightfield::from_samples(4, 4, (0..16).map(|i| i as f32 / 15.0).collect());
        if let Ok(t) = hf.to_texture(hikage_bundle::TextureFormat::R16Float)
            && let Ok(bytes) = hikage_bundle::ktx2_file::encode(&t, "fuzz")
        {
            let _ = std::fs::write(scratch().join("bundle").join("t.ktx2"), bytes);
        }
    });
    if std::fs::write(dir.join(hikage_bundle::MANIFEST_FILE), data).is_err() {
        return;
    }
    let _ = hikage_bundle::validate(&dir);
    if let Ok(b) = hikage_bundle::Bundle::open(&dir) {
        for a in &b.manifest().assets {
            let _ = b.read_payload(a);
            let _ = b.read_texture(&a.id);
            let _ = b.read_mesh(&a.id);
        }
    }
}

/// KTX2 bytes → the reader's header check and full decode (default limits).
pub fn ktx2(data: &[u8]) {
    let path = Path::new("<fuzz>.ktx2");
    let limits = Limits::default();
    let _ = hikage_bundle::ktx2_file::read_desc(data, path, &limits);
    let _ = hikage_bundle::ktx2_file::decode(data, path, &limits);
}

/// `.hair` bytes → [`hikage_bake::strands::cyhair::decode`], and strips of what it accepts.
pub fn hair(data: &[u8]) {
    let limits = hikage_bake::strands::cyhair::HairLimits { max_strands: 100_000, max_points: 1_000_000 };
    if let Ok(s) = hikage_bake::strands::cyhair::decode(data, &limits) {
        let sets = hikage_bake::strands::strips::StripSets::from_source(&s);
        let _ = hikage_bake::strands::strips::build(&s, &sets);
    }
}

/// OBJ text → [`hikage_bake::strands::obj::parse`] (polylines), and strips of what it accepts.
pub fn obj_polylines(data: &[u8]) {
    if let Ok(text) = std::str::from_utf8(data)
        && let Ok(s) = hikage_bake::strands::obj::parse(text, 1_000_000)
    {
        let sets = hikage_bake::strands::strips::StripSets::from_source(&s);
        let _ = hikage_bake::strands::strips::build(&s, &sets);
    }
}

/// `pipeline.ron` text → parse and check every job's settings.
pub fn pipeline(data: &[u8]) {
    if let Ok(text) = std::str::from_utf8(data) {
        let path = Path::new("<fuzz>/pipeline.ron");
        if let Ok(p) = hikage_bake::Pipeline::parse(text, path) {
            let _ = p.check(path);
        }
    }
}

/// Image bytes (PNG, OpenEXR, TIFF) → [`hikage_bake::heightfield::load_samples`] (sides up to 1024).
pub fn heightfield(data: &[u8]) {
    let path = scratch().join("heightfield");
    if std::fs::write(&path, data).is_ok() {
        let options = hikage_bake::LoadOptions { max_dimension: 1024, ..Default::default() };
        let _ = hikage_bake::heightfield::load_samples(&path, &options);
    }
}

/// Mesh bytes → [`hikage_bake::mesh::load`] as glTF (`.gltf`: GLB or JSON) and as OBJ, then
/// curvature of what they accept (files up to 1 MiB).
pub fn mesh(data: &[u8]) {
    let limits = hikage_bake::mesh::MeshLimits { max_bytes: 1 << 20 };
    for name in ["mesh.gltf", "mesh.obj"] {
        let path = scratch().join(name);
        if std::fs::write(&path, data).is_ok()
            && let Ok(m) = hikage_bake::mesh::load(&path, limits)
        {
            let _ = hikage_bake::curvature::compute(&m);
        }
    }
}

/// A fuzz entry point.
pub type Target = fn(&[u8]);

/// The targets by name, for the regression replay.
pub const TARGETS: [(&str, Target); 8] = [
    ("manifest", manifest),
    ("bundle", bundle),
    ("ktx2", ktx2),
    ("hair", hair),
    ("obj_polylines", obj_polylines),
    ("pipeline", pipeline),
    ("heightfield", heightfield),
    ("mesh", mesh),
];
