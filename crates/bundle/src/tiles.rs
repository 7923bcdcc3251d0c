//! Tile tables: how a map baked in tiles is written into a manifest that scales.
//!
//! A map baked in tiles has thousands of payloads (a 65536² map in 512² tiles with every level
//! of detail holds 21,845 tiles of up to three payloads each). Listing each as its own entry of
//! `bundle.ron` would make the manifest tens of megabytes of RON. Since format 1.9 the writer
//! stores them as one [`TileSet`] per map instead: `bundle.ron` holds, per kind of payload, one
//! *part* (the entry every tile's payload shares, with the per-tile fields left empty), and a
//! binary *tile table* file holds one fixed-size record per payload with what differs — level,
//! grid index, origin, size, byte length, BLAKE3 and input hash.
//!
//! A tile's payload stays a file of its own (`<part>.<x>_<y>.<hash>.ktx2`, `L<k>` before the
//! index for level `k` > 0), so a game or a web server fetches one file per tile. Readers see
//! every tile as an ordinary [`Asset`] in [`crate::Manifest::assets`]: the table is a way of
//! writing the manifest, not a second model of it, so validation, inspection, export, shards
//! and merges treat tiles as they treat every asset.
//!
//! A payload is written into a table only when its entry is rebuilt from the part and the record
//! exactly as it was; anything else (a hand-written entry, an unusual name) stays a plain entry.
//! [`find_tile`] reads one tile's entry from a table without reading the rest of it.
//!
//! The table file (little-endian): the 8 bytes `HKTILES1`, the record size (`u32`, 100) and a
//! reserved `u32` (0), then the records sorted by the ids of the tiles they stand for (a reader
//! finds one by binary search), each on its part and level's grid (its origin its grid index
//! times the size of tile `(0, 0)`):
//!
//! | bytes | field |
//! |---|---|
//! | 2 | part (index into [`TileSet::parts`]) |
//! | 2 | level of detail |
//! | 4 + 4 | column and row in the level's grid of tiles |
//! | 4 + 4 | first texel's column and row in the level's map |
//! | 4 + 4 | width and height in texels |
//! | 8 | payload byte length |
//! | 32 | payload BLAKE3 |
//! | 32 | input hash |

use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::asset::{Asset, Payload};
use crate::error::BundleError;
use crate::names::payload_file_name;
use crate::settings::{AmbientOcclusionSettings, HeightfieldSettings, HorizonSettings, Settings, TilePlacement};
use crate::texture::TextureDesc;

/// The table file's first eight bytes.
const MAGIC: &[u8; 8] = b"HKTILES1";
/// Bytes before the first record.
const HEADER_BYTES: u64 = 16;
/// Bytes of one record.
pub const RECORD_BYTES: u64 = 100;

/// One map's tiles as `bundle.ron` lists them (format 1.9): the parts, and the table file with
/// one record per tile payload.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TileSet {
    /// The map's name (the job id), as every tile's [`TilePlacement::map`].
    pub map: String,
    /// The table file, relative to the bundle directory.
    pub table: String,
    /// Size of the table file in bytes.
    pub byte_length: u64,
    /// BLAKE3 of the table file, lower-case hex.
    pub blake3: String,
    /// Records in the table.
    pub records: u64,
    /// What every tile's payload of a kind shares: an entry whose id is the part's (the tiles'
    /// ids less their suffix), with an empty file name and hashes, zero byte length and size,
    /// and the tile placement at level 0, index and origin zero.
    pub parts: Vec<Asset>,
}

/// What one record holds: the fields in which one tile's entry differs from its part's.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Record {
    part: u16,
    level: u16,
    index: (u32, u32),
    origin: (u32, u32),
    size: (u32, u32),
    byte_length: u64,
    blake3: [u8; 32],
    input_hash: [u8; 32],
}

/// Tile table files a manifest names: each file's name and bytes.
pub type TableFiles = Vec<(String, Vec<u8>)>;

/// A map's parts, and its records with the ids they stand for.
type MapTiles<'a> = (Vec<Asset>, Vec<(&'a str, Record)>);

/// The suffix a tile's ids carry after its part's id: `.<x>_<y>` at level 0, `.L<k>.<x>_<y>`
/// at level `k`.
pub fn tile_suffix(level: u32, index: (u32, u32)) -> String {
    match level {
        0 => format!(".{}_{}", index.0, index.1),
        k => format!(".L{k}.{}_{}", index.0, index.1),
    }
}

/// The id of part `part`'s tile at `level`, column and row `index`: the part's id and
/// [`tile_suffix`] (`terrain.horizon.3_5`, `terrain.horizon.L2.3_5`).
pub fn tile_id(part: &str, level: u32, index: (u32, u32)) -> String {
    format!("{part}{}", tile_suffix(level, index))
}

/// The part of tile `id` placed at `placement` (its id less the suffix), or `None` when the id
/// does not end as that placement's tiles do.
pub fn tile_part<'a>(id: &'a str, placement: &TilePlacement) -> Option<&'a str> {
    id.strip_suffix(&tile_suffix(placement.level, placement.index))
}

/// The asset a part and a record make.
fn expand(part: &Asset, r: &Record) -> Asset {
    let suffix = tile_suffix(r.level as u32, r.index);
    let with_suffix = |s: &str| {
        let mut out = String::with_capacity(s.len() + suffix.len());
        out.push_str(s);
        out.push_str(&suffix);
        out
    };
    let id = with_suffix(&part.id);
    let blake3 = hex(&r.blake3);
    let (payload, ext) = match &part.payload {
        Payload::Texture(t) => {
            let (width, height) = r.size;
            (Payload::Texture(TextureDesc { width, height, channels: t.channels.clone(), ..*t }), "ktx2")
        }
        Payload::Mesh(m) => (Payload::Mesh(m.clone()), "bin"),
    };
    let place = |p: &Option<TilePlacement>| {
        p.as_ref().map(|p| TilePlacement {
            map: p.map.clone(),
            index: r.index,
            origin: r.origin,
            map_size: p.map_size,
            level: r.level as u32,
        })
    };
    let settings = match &part.settings {
        Settings::Heightfield(h) => Settings::Heightfield(HeightfieldSettings {
            source_channel: h.source_channel.clone(),
            tile: place(&h.tile),
            ..*h
        }),
        Settings::Horizon(h) => {
            Settings::Horizon(HorizonSettings { heightfield: with_suffix(&h.heightfield), tile: place(&h.tile), ..*h })
        }
        Settings::AmbientOcclusion(o) => Settings::AmbientOcclusion(AmbientOcclusionSettings {
            horizon: with_suffix(&o.horizon),
            directions: o.directions,
            tile: place(&o.tile),
        }),
        other => other.clone(),
    };
    Asset {
        file: payload_file_name(&id, &blake3, ext),
        id,
        kind: part.kind,
        byte_length: r.byte_length,
        blake3,
        input_hash: hex(&r.input_hash),
        payload,
        settings,
    }
}

/// The part and record of a tile's entry, when rebuilding it from them gives the entry back.
fn split(asset: &Asset) -> Option<(Asset, Record)> {
    let p = asset.settings.tile()?;
    let Payload::Texture(t) = &asset.payload else { return None };
    let level = u16::try_from(p.level).ok()?;
    let suffix = tile_suffix(p.level, p.index);
    let mut part = asset.clone();
    part.id = asset.id.strip_suffix(&suffix)?.to_string();
    (part.file, part.byte_length, part.blake3, part.input_hash) = (String::new(), 0, String::new(), String::new());
    if let Payload::Texture(t) = &mut part.payload {
        (t.width, t.height) = (0, 0);
    }
    let blank = |p: &mut TilePlacement| {
        (p.level, p.index, p.origin) = (0, (0, 0), (0, 0));
    };
    match &mut part.settings {
        Settings::Heightfield(h) => h.tile.as_mut().map(blank),
        Settings::Horizon(h) => {
            h.heightfield = h.heightfield.strip_suffix(&suffix)?.to_string();
            h.tile.as_mut().map(blank)
        }
        Settings::AmbientOcclusion(o) => {
            o.horizon = o.horizon.strip_suffix(&suffix)?.to_string();
            o.tile.as_mut().map(blank)
        }
        _ => None,
    };
    let record = Record {
        part: 0,
        level,
        index: p.index,
        origin: p.origin,
        size: (t.width, t.height),
        byte_length: asset.byte_length,
        blake3: unhex(&asset.blake3)?,
        input_hash: unhex(&asset.input_hash)?,
    };
    (expand(&part, &record) == *asset).then_some((part, record))
}

/// A manifest's assets as `bundle.ron` writes them: the plain entries, and per tiled map its
/// tile set with the table file's name and bytes.
pub(crate) fn pack(assets: &[Asset]) -> (Vec<Asset>, Vec<(TileSet, Vec<u8>)>) {
    let mut plain = Vec::new();
    // Per map: its parts and records, maps in name order.
    let mut maps: std::collections::BTreeMap<String, MapTiles> = Default::default();
    for a in assets {
        let Some((part, mut record)) = split(a) else {
            plain.push(a.clone());
            continue;
        };
        let map = a.settings.tile().map(|p| p.map.clone()).unwrap_or_default();
        let (parts, records) = maps.entry(map).or_default();
        let index = match parts.iter().position(|p| *p == part) {
            Some(i) => i,
            None => {
                parts.push(part);
                parts.len() - 1
            }
        };
        let Ok(index) = u16::try_from(index) else {
            plain.push(a.clone());
            continue;
        };
        record.part = index;
        records.push((a.id.as_str(), record));
    }
    let sets = maps
        .into_iter()
        .map(|(map, (parts, mut records))| {
            // In id order: a reader's assets come out sorted, and one is found by its id.
            records.sort_by(|a, b| a.0.cmp(b.0));
            let records: Vec<Record> = records.into_iter().map(|(_, r)| r).collect();
            let bytes = table_bytes(&records);
            let blake3 = blake3::hash(&bytes).to_hex().to_string();
            let table = payload_file_name(&format!("{map}.tile-table"), &blake3, "bin");
            let set =
                TileSet { map, table, byte_length: bytes.len() as u64, blake3, records: records.len() as u64, parts };
            (set, bytes)
        })
        .collect();
    (plain, sets)
}

fn table_bytes(records: &[Record]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_BYTES as usize + records.len() * RECORD_BYTES as usize);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&(RECORD_BYTES as u32).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    for r in records {
        out.extend_from_slice(&r.part.to_le_bytes());
        out.extend_from_slice(&r.level.to_le_bytes());
        for v in [r.index.0, r.index.1, r.origin.0, r.origin.1, r.size.0, r.size.1] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&r.byte_length.to_le_bytes());
        out.extend_from_slice(&r.blake3);
        out.extend_from_slice(&r.input_hash);
    }
    out
}

fn read_record(b: &[u8]) -> Record {
    let u32_at = |i: usize| u32::from_le_bytes(b[i..i + 4].try_into().expect("4 bytes"));
    Record {
        part: u16::from_le_bytes([b[0], b[1]]),
        level: u16::from_le_bytes([b[2], b[3]]),
        index: (u32_at(4), u32_at(8)),
        origin: (u32_at(12), u32_at(16)),
        size: (u32_at(20), u32_at(24)),
        byte_length: u64::from_le_bytes(b[28..36].try_into().expect("8 bytes")),
        blake3: b[36..68].try_into().expect("32 bytes"),
        input_hash: b[68..100].try_into().expect("32 bytes"),
    }
}

/// Checks a table's size against its set before anything is read: what the file must hold.
pub(crate) fn expected_bytes(set: &TileSet, max_records: u64) -> Result<u64, String> {
    if set.records > max_records {
        return Err(format!("{} records, above the limit of {max_records}", set.records));
    }
    let expected = HEADER_BYTES + set.records * RECORD_BYTES;
    if set.byte_length != expected {
        return Err(format!(
            "byte_length {} but {} records of {RECORD_BYTES} bytes and a {HEADER_BYTES}-byte header make {expected}",
            set.byte_length, set.records
        ));
    }
    if set.parts.len() > u16::MAX as usize + 1 {
        return Err(format!("{} parts; a record names at most {}", set.parts.len(), u16::MAX as u32 + 1));
    }
    Ok(expected)
}

/// A set's table file `bytes` (already read) against what a reader relies on: the file's size,
/// hash and header, and every record naming a part of the set and a tile of its map, in id
/// order, on its grid ([`check_records`]).
pub(crate) fn check(set: &TileSet, bytes: &[u8], max_records: u64) -> Result<(), String> {
    check_table(set, bytes, max_records)?;
    check_records(set, bytes)
}

/// The first tile of each part of a set whose table `bytes` passed [`check`]: what stands for
/// the rest of the part when checking it as a reader of the full manifest would (the tiles
/// differ only in numbers `check` checked).
pub(crate) fn first_tiles(set: &TileSet, bytes: &[u8]) -> Vec<Asset> {
    let mut first: Vec<Option<Asset>> = vec![None; set.parts.len()];
    // `check` said every record names a part of the set.
    for r in bytes[HEADER_BYTES as usize..].chunks_exact(RECORD_BYTES as usize).map(read_record) {
        let slot = &mut first[r.part as usize];
        if slot.is_none() {
            *slot = Some(expand(&set.parts[r.part as usize], &r));
        }
    }
    first.into_iter().flatten().collect()
}

/// The tiles of a set whose table `bytes` passed [`check`], as assets, in the table's order.
pub(crate) fn tile_assets<'a>(set: &'a TileSet, bytes: &'a [u8]) -> impl Iterator<Item = Asset> + 'a {
    // `check` said every record names a part of the set.
    let records = bytes[HEADER_BYTES as usize..].chunks_exact(RECORD_BYTES as usize).map(read_record);
    records.map(|r| expand(&set.parts[r.part as usize], &r))
}

/// The records of a table whose bytes passed [`check_table`], against what a reader relies on:
/// each names a part of the set; they are in strictly increasing id order (a reader finds a tile
/// by binary search on its id); and each lies on its part and level's grid — column `i` starts
/// at `i` times one step, row `j` likewise — and fits the part's map. A shard's table holds some
/// of a grid's tiles: the step is what any of them gives.
fn check_records(set: &TileSet, bytes: &[u8]) -> Result<(), String> {
    let records = || bytes[HEADER_BYTES as usize..].chunks_exact(RECORD_BYTES as usize).map(read_record);
    // Per part, level and axis: the step (the origin over the index of the first tile past
    // the first column or row).
    type Axis = Option<u64>;
    let mut grids: std::collections::HashMap<(u16, u16), [Axis; 2]> = Default::default();
    for (i, r) in records().enumerate() {
        record_part(set, i, &r)?;
        let axes = grids.entry((r.part, r.level)).or_default();
        for (axis, index, origin) in [(0, r.index.0, r.origin.0), (1, r.index.1, r.origin.1)] {
            let step = &mut axes[axis];
            if index > 0 && step.is_none() {
                *step = Some(origin as u64 / index as u64);
            }
        }
    }
    let on_grid = |index: u32, origin: u32, step: Axis, name: &str| -> Result<(), String> {
        let step = step.unwrap_or(0);
        if index > 0 && step == 0 {
            return Err(format!("grid {name} {index} at {origin}: tiles past the first {name} start at 0"));
        }
        if origin as u64 != index as u64 * step {
            return Err(format!("grid {name} {index} starts at {origin}, not at {index} × {step}"));
        }
        Ok(())
    };
    let mut previous = String::new();
    for (i, r) in records().enumerate() {
        let part = &set.parts[r.part as usize];
        let id = tile_id(&part.id, r.level as u32, r.index);
        if i > 0 && id <= previous {
            return Err(format!(
                "record {i} (`{id}`) does not come after record {} (`{previous}`): records are sorted by id, and \
                 a reader looks tiles up by binary search",
                i - 1
            ));
        }
        let [x, y] = grids[&(r.part, r.level)];
        let map_size = part.settings.tile().map_or((0, 0), |p| p.map_size);
        let fits = |o: u32, n: u32, size: u32| o as u64 + n as u64 <= size as u64;
        on_grid(r.index.0, r.origin.0, x, "column")
            .and_then(|()| on_grid(r.index.1, r.origin.1, y, "row"))
            .and_then(|()| match fits(r.origin.0, r.size.0, map_size.0) && fits(r.origin.1, r.size.1, map_size.1) {
                true => Ok(()),
                false => Err(format!("a {:?} tile at {:?} does not fit its {map_size:?} map", r.size, r.origin)),
            })
            .map_err(|m| format!("record {i} (`{id}`): {m}"))?;
        previous = id;
    }
    Ok(())
}

/// A table's bytes against its set's entry: their length, BLAKE3 and header.
fn check_table(set: &TileSet, bytes: &[u8], max_records: u64) -> Result<(), String> {
    let expected = expected_bytes(set, max_records)?;
    if bytes.len() as u64 != expected {
        return Err(format!("the file is {} bytes, the manifest says {expected}", bytes.len()));
    }
    let hash = blake3::hash(bytes).to_hex();
    if hash.as_str() != set.blake3 {
        return Err(format!("BLAKE3 is {hash}, the manifest says {} (the file was modified or corrupted)", set.blake3));
    }
    check_header(bytes)
}

/// The part record `i` names, which must be a tile of the set's map.
fn record_part<'a>(set: &'a TileSet, i: usize, r: &Record) -> Result<&'a Asset, String> {
    match set.parts.get(r.part as usize) {
        Some(part) if part.settings.tile().is_some_and(|t| t.map == set.map) => Ok(part),
        Some(part) => Err(format!("part `{}` is not a tile of map `{}`", part.id, set.map)),
        None => Err(format!("record {i} names part {} of a set of {} parts", r.part, set.parts.len())),
    }
}

fn check_header(bytes: &[u8]) -> Result<(), String> {
    if bytes.len() < HEADER_BYTES as usize || &bytes[..8] != MAGIC {
        return Err("expected a tile table starting with HKTILES1".into());
    }
    let size = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if size as u64 != RECORD_BYTES {
        return Err(format!("expected {RECORD_BYTES}-byte records, the header says {size}"));
    }
    Ok(())
}

/// One tile's entry, read from its map's table without reading the other records: the part
/// named `part` (a tile's id less its suffix, e.g. `terrain.horizon`), at `level`, column and
/// row `index`. `None` when the set has no such tile. The record is found by binary search on
/// the table's records, sorted by id; the table's hash is not checked (the payload's own hash
/// still is, when read).
///
/// ```no_run
/// use hikage_bundle::tiles::{TileSet, find_tile};
/// # fn f(set: &TileSet) -> Result<(), hikage_bundle::BundleError> {
/// // The horizon tile at column 3, row 5 of level 2.
/// if let Some(tile) = find_tile("bundle".as_ref(), set, "terrain.horizon", 2, (3, 5))? {
///     println!("{} is {} bytes", tile.file, tile.byte_length);
/// }
/// # Ok(()) }
/// ```
pub fn find_tile(
    dir: &Path,
    set: &TileSet,
    part: &str,
    level: u32,
    index: (u32, u32),
) -> Result<Option<Asset>, BundleError> {
    let path = dir.join(&set.table);
    let Ok(level) = u16::try_from(level) else { return Ok(None) };
    let bad = |message: String| BundleError::Payload { path: path.clone(), asset: set.map.clone(), message };
    let expected = expected_bytes(set, u64::MAX / RECORD_BYTES / 2).map_err(bad)?;
    let mut file = crate::files::open_in_bundle(&path).map_err(|e| BundleError::io(&path, e))?;
    let len = file.metadata().map_err(|e| BundleError::io(&path, e))?.len();
    if len != expected {
        return Err(bad(format!("the file is {len} bytes, the manifest says {expected}")));
    }
    let mut header = [0u8; HEADER_BYTES as usize];
    file.read_exact(&mut header).map_err(|e| BundleError::io(&path, e))?;
    check_header(&header).map_err(bad)?;
    let id = tile_id(part, level as u32, index);
    let mut buf = [0u8; RECORD_BYTES as usize];
    let read = |i: u64| {
        file.seek(SeekFrom::Start(HEADER_BYTES + i * RECORD_BYTES)).map_err(|e| BundleError::io(&path, e))?;
        file.read_exact(&mut buf).map_err(|e| BundleError::io(&path, e))?;
        Ok(read_record(&buf))
    };
    search(set, &id, read, |i| bad(format!("record {i} names no part")))
}

/// The entry of tile `id` in `set`, whose table `bytes` (in memory) passed [`check`]; `None`
/// when the set has no such tile.
pub(crate) fn find_in_table(set: &TileSet, bytes: &[u8], id: &str) -> Option<Asset> {
    let records = &bytes[HEADER_BYTES as usize..];
    let read = |i: u64| Ok(read_record(&records[(i * RECORD_BYTES) as usize..][..RECORD_BYTES as usize]));
    // `check` said every record names a part.
    search(set, id, read, |_| ()).ok().flatten()
}

/// The entry of tile `id` in `set`, found by binary search on its records (sorted by id), each
/// read by `read`; `no_part(i)` is the error of a record `i` naming a part the set lacks.
fn search<E>(
    set: &TileSet,
    id: &str,
    mut read: impl FnMut(u64) -> Result<Record, E>,
    no_part: impl Fn(u64) -> E,
) -> Result<Option<Asset>, E> {
    let (mut lo, mut hi) = (0u64, set.records);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        let r = read(mid)?;
        let part = set.parts.get(r.part as usize).ok_or_else(|| no_part(mid))?;
        let found = tile_id(&part.id, r.level as u32, r.index);
        match found.as_str().cmp(id) {
            std::cmp::Ordering::Less => lo = mid + 1,
            std::cmp::Ordering::Greater => hi = mid,
            std::cmp::Ordering::Equal => return Ok(Some(expand(part, &r))),
        }
    }
    Ok(None)
}

fn hex(bytes: &[u8; 32]) -> String {
    const DIGITS: &[u8; 16] = b"0123456789abcdef";
    let mut out = Vec::with_capacity(64);
    for b in bytes {
        out.extend_from_slice(&[DIGITS[(b >> 4) as usize], DIGITS[(b & 15) as usize]]);
    }
    String::from_utf8(out).expect("hex digits are ASCII")
}

fn unhex(s: &str) -> Option<[u8; 32]> {
    if s.len() != 64 || !s.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f')) {
        return None;
    }
    let mut out = [0u8; 32];
    for (i, o) in out.iter_mut().enumerate() {
        *o = u8::from_str_radix(&s[2 * i..2 * i + 2], 16).ok()?;
    }
    Some(out)
}
