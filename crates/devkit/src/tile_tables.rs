//! Synthetic manifests of maps baked in tiles, for measuring tile tables at sizes no test bakes
//! (a 65536² pyramid) and for the test that opens and validates 20,000 tiles.

use hikage_bundle::{
    AmbientOcclusionSettings, Asset, AssetKind, EdgeMode, HeightfieldSettings, HorizonSettings, Payload, Settings,
    Supercompression, TextureDesc, TextureDimension, TextureFormat, TilePlacement, payload_file_name,
};

/// Which payloads each tile of [`pyramid`] has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Parts {
    /// Heights only.
    Heights,
    /// Heights, horizons and occlusion, as a tiled `Horizon` job with `ao` bakes.
    All,
}

/// Every tile of a `size`² map in `tile`² tiles at every level down to one tile, with `parts`:
/// entries as a tiled bake writes them, each payload's hash taken from `hash(id)` (the bytes a
/// test wrote, or any 64 hex digits when only the manifest is measured).
pub fn pyramid(
    map: &str,
    size: u32,
    tile: u32,
    parts: Parts,
    byte_length: u64,
    hash: &dyn Fn(&str) -> String,
) -> Vec<Asset> {
    let mut assets = Vec::new();
    let mut level = 0;
    loop {
        let n = (size >> level).max(1);
        let count = (n - 1).div_ceil(tile).max(1);
        for ty in 0..count {
            for tx in 0..count {
                let origin = (tx * tile, ty * tile);
                let extent = ((tile + 1).min(n - origin.0), (tile + 1).min(n - origin.1));
                let place = TilePlacement { map: map.into(), index: (tx, ty), origin, map_size: (n, n), level };
                let suffix = hikage_bundle::tiles::tile_suffix(level, (tx, ty));
                let texel = (1u32 << level) as f32;
                let entry = |part: &str, format, dimension, depth, channels: &[&str], settings| {
                    let id = format!("{map}.{part}{suffix}");
                    let blake3 = hash(&id);
                    Asset {
                        file: payload_file_name(&id, &blake3, "ktx2"),
                        byte_length,
                        blake3,
                        input_hash: hash(&format!("{id} input")),
                        kind: AssetKind::Heightfield,
                        payload: Payload::Texture(TextureDesc {
                            format,
                            dimension,
                            width: extent.0,
                            height: extent.1,
                            depth,
                            layers: 1,
                            levels: 1,
                            supercompression: Supercompression::None,
                            channels: channels.iter().map(|c| c.to_string()).collect(),
                        }),
                        settings,
                        id,
                    }
                };
                let heights = Settings::Heightfield(HeightfieldSettings {
                    texel_size: (texel, texel),
                    height_scale: 1.0,
                    height_offset: 0.0,
                    source_channel: "height".into(),
                    normalized: false,
                    tile: Some(place.clone()),
                });
                assets.push(entry("height", TextureFormat::R32Float, TextureDimension::D2, 1, &["height"], heights));
                if parts == Parts::All {
                    let horizon = Settings::Horizon(HorizonSettings {
                        heightfield: format!("{map}.height{suffix}"),
                        directions: 16,
                        edge: EdgeMode::Clamp,
                        max_distance: Some(4000.0),
                        near_field: 8,
                        texel_size: (texel, texel),
                        height_scale: 1.0,
                        open_sky_slope: -1e9,
                        distance_scale: 1.0,
                        tile: Some(place.clone()),
                    });
                    let mut h = entry(
                        "horizon",
                        TextureFormat::Rg16Float,
                        TextureDimension::D3,
                        16,
                        &["slope", "distance"],
                        horizon,
                    );
                    h.kind = AssetKind::Horizon;
                    let ao = Settings::AmbientOcclusion(AmbientOcclusionSettings {
                        horizon: h.id.clone(),
                        directions: 16,
                        tile: Some(place.clone()),
                    });
                    let mut a = entry("ao", TextureFormat::R8Unorm, TextureDimension::D2, 1, &["occlusion"], ao);
                    a.kind = AssetKind::AmbientOcclusion;
                    assets.extend([h, a]);
                }
            }
        }
        if count == 1 {
            return assets;
        }
        level += 1;
    }
}
