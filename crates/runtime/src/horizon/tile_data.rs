//! What one tile of a streamed map holds, whatever engine streams it: the bytes its textures
//! take on the device, its heights with an apron of its neighbours' (so edge normals are the
//! whole map's), and whether a rebake left it as it was.

use hikage_bundle::{Asset, TextureData, TextureDesc};

use super::tile_plan::{TileKey, TileParts};

/// What a tile's textures take on the device: each part's texture, the heights with the
/// one-texel apron of [`heights_with_apron`].
pub fn tile_device_bytes(entries: &[Asset]) -> u64 {
    entries
        .iter()
        .filter_map(|a| {
            let t = a.payload.texture()?;
            let apron = if a.settings.heightfield().is_some() { 2 } else { 0 };
            TextureDesc { width: t.width + apron, height: t.height + apron, ..t.clone() }.total_bytes()
        })
        .sum()
}

/// Whether tile `key` reads the same files after a rebake, so an engine may keep it: each
/// part's entry and its neighbours' heights (its apron), as `entries(part, key)` gives them
/// (before, after), alike in file and BLAKE3.
///
/// ```no_run
/// # fn f(layout: &hikage_runtime::horizon::TileLayout, before: &hikage_runtime::hikage_bundle::tile_index::TileIndex,
/// #      after: &hikage_runtime::hikage_bundle::tile_index::TileIndex) {
/// use hikage_runtime::horizon::tile_unchanged;
///
/// let keep = tile_unchanged(&layout.parts, (0, 3, 5), |part, (level, x, y)| {
///     (before.tile(part, level, (x, y)), after.tile(part, level, (x, y)))
/// });
/// # }
/// ```
pub fn tile_unchanged(
    parts: &TileParts,
    key: TileKey,
    entries: impl Fn(&str, TileKey) -> (Option<Asset>, Option<Asset>),
) -> bool {
    let same = |part: &str, k: TileKey| {
        let (a, b) = entries(part, k);
        a.map(|a| (a.file, a.blake3)) == b.map(|b| (b.file, b.blake3))
    };
    parts.all().all(|p| same(p, key)) && apron_neighbours(key).into_iter().flatten().all(|n| same(&parts.height, n))
}

/// The keys of the tiles beside `key` whose heights [`heights_with_apron`] takes:
/// `[left, right, above, below]`, `None` past the map's first row or column.
pub fn apron_neighbours((level, x, y): TileKey) -> [Option<TileKey>; 4] {
    [
        x.checked_sub(1).map(|x| (level, x, y)),
        Some((level, x + 1, y)),
        y.checked_sub(1).map(|y| (level, x, y)),
        Some((level, x, y + 1)),
    ]
}

/// A tile's `heights` with one more texel on every side, so that its edge nodes' normals are
/// the whole map's: next to each edge the texel beside the shared edge in the neighbouring
/// tile (`[left, right, above, below]`, as [`apron_neighbours`] names them), or the edge texel
/// itself at the map's edge (as the one-mesh terrain clamps).
pub fn heights_with_apron(
    heights: &TextureData,
    [left, right, above, below]: &[Option<TextureData>; 4],
) -> TextureData {
    let (w, h) = (heights.desc.width as usize, heights.desc.height as usize);
    let tb = heights.desc.format.texel_bytes();
    let src = &heights.levels[0];
    let (aw, ah) = (w + 2, h + 2);
    let mut out = vec![0u8; aw * ah * tb];
    let texel = |t: &TextureData, x: usize, y: usize| -> Vec<u8> {
        let tw = t.desc.width as usize;
        t.levels[0][(y * tw + x) * tb..][..tb].to_vec()
    };
    let put = |out: &mut Vec<u8>, x: usize, y: usize, v: &[u8]| out[(y * aw + x) * tb..][..tb].copy_from_slice(v);
    // A neighbour of another size (none in a bake: a row of tiles shares its rows) is ignored.
    let l = left.as_ref().filter(|t| t.desc.height as usize == h && t.desc.width >= 2);
    let r = right.as_ref().filter(|t| t.desc.height as usize == h && t.desc.width >= 2);
    let a = above.as_ref().filter(|t| t.desc.width as usize == w && t.desc.height >= 2);
    let b = below.as_ref().filter(|t| t.desc.width as usize == w && t.desc.height >= 2);
    for y in 0..h {
        out[((y + 1) * aw + 1) * tb..][..w * tb].copy_from_slice(&src[y * w * tb..][..w * tb]);
        put(&mut out, 0, y + 1, &l.map_or_else(|| texel(heights, 0, y), |t| texel(t, t.desc.width as usize - 2, y)));
        put(&mut out, w + 1, y + 1, &r.map_or_else(|| texel(heights, w - 1, y), |t| texel(t, 1, y)));
    }
    for x in 0..w {
        put(&mut out, x + 1, 0, &a.map_or_else(|| texel(heights, x, 0), |t| texel(t, x, t.desc.height as usize - 2)));
        put(&mut out, x + 1, h + 1, &b.map_or_else(|| texel(heights, x, h - 1), |t| texel(t, x, 1)));
    }
    for (cx, cy, sx, sy) in [(0, 0, 0, 0), (w + 1, 0, w - 1, 0), (0, h + 1, 0, h - 1), (w + 1, h + 1, w - 1, h - 1)] {
        put(&mut out, cx, cy, &texel(heights, sx, sy));
    }
    let desc = TextureDesc { width: aw as u32, height: ah as u32, levels: 1, ..heights.desc.clone() };
    TextureData { desc, levels: vec![out] }
}
