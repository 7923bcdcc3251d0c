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

/// The strand limits the fuzz targets read under.
const HAIR_LIMITS: hikage_bake::strands::cyhair::HairLimits =
    hikage_bake::strands::cyhair::HairLimits { max_strands: 100_000, max_points: 1_000_000 };

/// Strips of strands a reader accepted, at the file's own widths.
fn strips(s: &hikage_bake::strands::Strands) {
    let sets = hikage_bake::strands::strips::StripSets::from_source(s);
    let _ = hikage_bake::strands::strips::build(s, &sets);
}

/// `.hair` bytes → [`hikage_bake::strands::cyhair::decode`], and strips of what it accepts.
pub fn hair(data: &[u8]) {
    if let Ok(s) = hikage_bake::strands::cyhair::decode(data, &HAIR_LIMITS) {
        strips(&s);
    }
}

/// OBJ text → [`hikage_bake::strands::obj::parse`] (polylines), and strips of what it accepts.
pub fn obj_polylines(data: &[u8]) {
    if let Ok(text) = std::str::from_utf8(data)
        && let Ok(s) = hikage_bake::strands::obj::parse(text, 1_000_000)
    {
        strips(&s);
    }
}

/// USD bytes → [`hikage_bake::strands::usd::load`] as `.usda` and as `.usdc`, and strips of what
/// it accepts (files up to 1 MiB).
pub fn usd_groom(data: &[u8]) {
    if data.len() > 1 << 20 {
        return;
    }
    for name in ["groom.usda", "groom.usdc"] {
        let path = scratch().join(name);
        if std::fs::write(&path, data).is_ok()
            && let Ok((s, _)) = hikage_bake::strands::usd::load(&path, &Default::default(), &HAIR_LIMITS)
        {
            strips(&s);
        }
    }
}

/// Alembic bytes → [`hikage_bake::strands::alembic::load`] (at the first sample and at a named
/// time), and strips of what it accepts (files up to 1 MiB).
pub fn alembic_groom(data: &[u8]) {
    if data.len() > 1 << 20 {
        return;
    }
    let path = scratch().join("groom.abc");
    if std::fs::write(&path, data).is_err() {
        return;
    }
    for time in [None, Some(1.0)] {
        let read = hikage_bake::strands::GroomRead { time, group: None };
        if let Ok((s, _)) = hikage_bake::strands::alembic::load(&path, &read, &HAIR_LIMITS) {
            strips(&s);
        }
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

/// A one-asset bundle (a 4×4 heightfield `t<k>`) in `dir`, for the targets that need parts or
/// payloads to point at; written once per process.
fn small_bundle(dir: &Path, k: u32) -> Option<hikage_bundle::Asset> {
    let _ = std::fs::remove_dir_all(dir);
    let mut writer = hikage_bundle::BundleWriter::open(dir, hikage_bundle::WriteMode::Replace).ok()?;
    let hf = hikage_bake::Heightfield::from_samples(4, 4, (0..16).map(|i| (i + k) as f32 / 31.0).collect());
    let texture = hf.to_texture(hikage_bundle::TextureFormat::R16Float).ok()?;
    let settings = hikage_bundle::Settings::Generic;
    let asset = writer.put_texture(&format!("t{k}"), settings, &"0".repeat(64), &texture).ok()?;
    writer.commit().ok()?;
    Some(asset)
}

/// `shard.ron` bytes → [`hikage_bake::shard::merge`] of two parts: a valid shard 0 of 2, and a
/// part whose record is `data` (its bundle valid). Whatever the record says, the merge gives a
/// bundle or an error, never a panic or an allocation the record sizes; a bundle it gives
/// validates.
pub fn shard_merge(data: &[u8]) {
    let root = scratch().join("merge");
    static PARTS: OnceLock<Option<()>> = OnceLock::new();
    let ready = PARTS.get_or_init(|| {
        for k in 0..2 {
            small_bundle(&root.join(format!("part{k}")), k)?;
        }
        let record = "(pipeline: \"".to_string() + &"a".repeat(64) + "\", shard: (index: 0, count: 2))";
        std::fs::write(root.join("part0").join(hikage_bake::shard::SHARD_FILE), record).ok()
    });
    if ready.is_none() || std::fs::write(root.join("part1").join(hikage_bake::shard::SHARD_FILE), data).is_err() {
        return;
    }
    let out = root.join("out");
    let _ = std::fs::remove_dir_all(&out);
    let parts = [root.join("part0"), root.join("part1")];
    if hikage_bake::shard::merge(&out, &parts, false).is_ok() {
        let report = hikage_bundle::validate(&out).expect("a merged bundle opens");
        assert!(report.is_valid(), "a merged bundle validates: {:?}", report.problems);
    }
}

/// `entry.ron` bytes of a cache entry beside one valid payload → [`hikage_bake::cache::Cache::get`]
/// for a job making `t0`. A hit is exactly the job's one asset, its payload intact; anything else
/// is a miss, never a panic.
pub fn cache_entry(data: &[u8]) {
    let root = scratch().join("cache");
    static ENTRY: OnceLock<Option<(hikage_bundle::Asset, PathBuf)>> = OnceLock::new();
    let hash = "0".repeat(64);
    let entry = ENTRY.get_or_init(|| {
        let asset = small_bundle(&root.join("bundle"), 0)?;
        Some((asset, root.join("cache").join(&hash[..2]).join(&hash)))
    });
    let Some((asset, dir)) = entry else { return };
    let Ok(cache) = hikage_bake::cache::Cache::open(&root.join("cache"), 1) else { return };
    // The entry as a baker would have stored it, its records replaced by `data`.
    let _ = std::fs::create_dir_all(dir);
    let _ = std::fs::copy(root.join("bundle").join(&asset.file), dir.join(&asset.file));
    if std::fs::write(dir.join("entry.ron"), data).is_err() {
        return;
    }
    if let Some(found) = cache.get(&hash, &["t0".to_string()]) {
        assert_eq!(found.len(), 1, "a hit holds exactly the job's assets");
        assert_eq!(found[0].0.id, "t0");
        assert_eq!(blake3::hash(&found[0].1).to_hex().as_str(), found[0].0.blake3);
    }
}

/// A fuzz entry point.
pub type Target = fn(&[u8]);

/// The targets by name, for the regression replay.
pub const TARGETS: [(&str, Target); 12] = [
    ("manifest", manifest),
    ("bundle", bundle),
    ("ktx2", ktx2),
    ("hair", hair),
    ("obj_polylines", obj_polylines),
    ("usd_groom", usd_groom),
    ("alembic_groom", alembic_groom),
    ("pipeline", pipeline),
    ("heightfield", heightfield),
    ("mesh", mesh),
    ("shard_merge", shard_merge),
    ("cache_entry", cache_entry),
];
