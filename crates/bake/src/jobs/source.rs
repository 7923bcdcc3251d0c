//! Where a heightfield-reading job's heights come from: the fields every such job writes
//! beside its own settings, declared, read, checked and hashed once.
//!
//! `pipeline.ron` writes them flat among the job's own fields —
//! `Horizon(id: "t", input: "t.png", texel_size: (80, 80), directions: 32)` — and a job holds
//! them as one [`HeightSource`]; [`deserialize_flat`] splits the one into the other, with the
//! job's own fields still refused by name when unknown and every error at its place in the file.
//! A new heightfield-reading job kind declares only its own settings.

use std::fmt;
use std::marker::PhantomData;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use serde::de::{self, DeserializeSeed, Deserializer, IntoDeserializer, MapAccess, Visitor};

use super::JobContext;
use crate::error::BakeError;
use crate::heightfield::{HeightFile, Heightfield, LoadOptions};

/// A heightfield input and its world units (`docs/conventions.md`): world height =
/// `height_offset + height_scale × sample`, integer images normalised to [0, 1] first.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct HeightSource {
    /// Heightfield: PNG (8/16-bit), OpenEXR, TIFF/GeoTIFF, SRTM .hgt, or raw .r16/.r32.
    pub input: PathBuf,
    /// Width and height of a raw .r16/.r32 input, WxH (none: a square map's side from its
    /// length).
    #[cfg_attr(feature = "clap", arg(long, value_name = "WxH", value_parser = parse_raw_size))]
    pub raw_size: Option<(u32, u32)>,
    /// Channel of the input to take: R, G, B, A, Y or an EXR channel name (default: a grayscale
    /// PNG's luma; an EXR's Y, else R, else its only channel).
    #[cfg_attr(feature = "clap", arg(long))]
    pub channel: Option<String>,
    /// World units per texel along u (columns) and v (rows): SX, or SX,SY.
    #[cfg_attr(feature = "clap", arg(long, value_name = "SX[,SY]", value_parser = parse_texel_size, default_value = "1"))]
    pub texel_size: (f32, f32),
    /// World height = height_offset + height_scale × sample (integer images normalised to [0, 1]
    /// first).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 1.0, allow_negative_numbers = true))]
    pub height_scale: f32,
    /// Added to every world height; see height_scale.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 0.0, allow_negative_numbers = true))]
    pub height_offset: f32,
}

impl HeightSource {
    /// The input `input` with every other field at its default: unit texels, scale 1, offset 0.
    pub fn new(input: impl Into<PathBuf>) -> HeightSource {
        HeightSource {
            input: input.into(),
            raw_size: None,
            channel: None,
            texel_size: (1.0, 1.0),
            height_scale: 1.0,
            height_offset: 0.0,
        }
    }

    /// The input file, resolved against `base_dir`.
    pub fn path(&self, base_dir: &Path) -> PathBuf {
        base_dir.join(&self.input)
    }

    /// How the input is read under `ctx`'s limits.
    pub fn load_options(&self, ctx: &JobContext) -> LoadOptions {
        LoadOptions { channel: self.channel.clone(), max_dimension: ctx.limits.max_dimension, raw_size: self.raw_size }
    }

    /// The input opened for reading, its header checked.
    pub fn open(&self, ctx: &JobContext) -> Result<HeightFile, BakeError> {
        HeightFile::open(&self.path(ctx.base_dir), &self.load_options(ctx))
    }

    /// Checks the world units without reading anything; the message says what is accepted.
    pub fn check(&self) -> Result<(), String> {
        let (sx, sy) = self.texel_size;
        if !(sx.is_finite() && sy.is_finite() && sx > 0.0 && sy > 0.0) {
            return Err(format!("texel_size must be finite and above 0, found ({sx}, {sy})"));
        }
        if !self.height_scale.is_finite() || !self.height_offset.is_finite() {
            return Err(format!(
                "height_scale and height_offset must be finite, found {} and {}",
                self.height_scale, self.height_offset
            ));
        }
        Ok(())
    }

    /// A sample's world height must be finite, and the sample pass the job's own `check`
    /// (its storage, its range).
    fn check_sample(&self, v: f32, check: &dyn Fn(f32) -> Result<(), String>) -> Result<(), String> {
        check(v)?;
        let world = hikage_bundle::world_height(self.height_offset, self.height_scale, v);
        if !world.is_finite() {
            return Err(format!(
                "sample {v} gives world height {world} (height_offset + height_scale × sample): expected a finite one"
            ));
        }
        Ok(())
    }

    /// The map's world extent, which horizon distances are measured in, must be finite.
    pub(super) fn check_extent(&self, path: &Path, (w, h): (u32, u32)) -> Result<(), BakeError> {
        let (sx, sy) = self.texel_size;
        if !((w as f32 * sx).is_finite() && (h as f32 * sy).is_finite()) {
            return Err(BakeError::input(
                path,
                None,
                format!("a {w}×{h} map of texel_size ({sx}, {sy}) spans no finite world extent"),
            ));
        }
        Ok(())
    }

    /// Checks `samples` of the map (a window from `origin`, `width` wide, around the torus of
    /// the map's `size`) as a load does; the error names the first bad pixel in map texels.
    pub(super) fn check_samples(
        &self,
        path: &Path,
        samples: &[f32],
        (origin, width, size): ((i64, i64), u32, (u32, u32)),
        check: &dyn Fn(f32) -> Result<(), String>,
    ) -> Result<(), BakeError> {
        self.check_extent(path, size)?;
        let bad = samples.iter().enumerate().find_map(|(i, &v)| self.check_sample(v, check).err().map(|m| (i, m)));
        match bad {
            Some((i, message)) => {
                let x = (origin.0 + (i % width as usize) as i64).rem_euclid(size.0 as i64);
                let y = (origin.1 + (i / width as usize) as i64).rem_euclid(size.1 as i64);
                Err(BakeError::input(path, Some(format!("pixel ({x}, {y})")), message))
            }
            None => Ok(()),
        }
    }

    /// A map baked whole becomes textures of its size: its sides must be within what one
    /// texture may have (a larger map is baked in tiles). The error names the input.
    pub(super) fn check_whole(&self, path: &Path, (w, h): (u32, u32)) -> Result<(), BakeError> {
        let limit = hikage_bundle::Limits::default().max_texture_dimension;
        if w.max(h) > limit {
            return Err(BakeError::Limit {
                path: path.to_path_buf(),
                what: format!(
                    "image dimension ({w}×{h}; a map baked whole is one texture of its size: a tiled Horizon job, \
                     `tile: Some(1024)`, bakes a larger one)"
                ),
                value: w.max(h) as u64,
                limit: limit as u64,
            });
        }
        Ok(())
    }

    /// Loads the whole map with the world units attached, every sample checked (finite, a
    /// finite world height, and `check`), its size within one texture's.
    pub fn load(&self, ctx: &JobContext, check: &dyn Fn(f32) -> Result<(), String>) -> Result<Heightfield, BakeError> {
        let path = self.path(ctx.base_dir);
        let file = self.open(ctx)?;
        self.check_whole(&path, file.size())?;
        let s = file.read_all()?;
        self.check_samples(&path, &s.values, ((0, 0), s.width, (s.width, s.height)), check)?;
        Ok(Heightfield {
            width: s.width,
            height: s.height,
            samples: s.values,
            texel_size: self.texel_size,
            height_scale: self.height_scale,
            height_offset: self.height_offset,
            normalized: s.normalized,
            source_channel: s.channel,
        })
    }

    /// Checks every sample as [`load`](Self::load) would, a block of the file at a time (the
    /// map need not fit in memory): `validate PIPELINE`'s check.
    /// With `whole`, the map is baked whole: its size must be one texture's
    /// ([`load`](Self::load)'s check).
    pub fn scan(
        &self,
        ctx: &JobContext,
        whole: bool,
        check: &dyn Fn(f32) -> Result<(), String>,
    ) -> Result<HeightFile, BakeError> {
        let path = self.path(ctx.base_dir);
        let mut file = self.open(ctx)?;
        if whole {
            self.check_whole(&path, file.size())?;
        }
        self.check_extent(&path, file.size())?;
        file.scan(&|v| self.check_sample(v, check))?;
        Ok(file)
    }
}

/// Parses a raw heightmap's size written `WxH` (the command line's `--raw-size`).
#[cfg(feature = "clap")]
pub fn parse_raw_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or("expected WxH")?;
    let num = |p: &str| p.trim().parse::<u32>().map_err(|e| format!("{p:?}: {e}"));
    Ok((num(w)?, num(h)?))
}

/// Parses a texel size written `SX` or `SX,SY` (the command line's `--texel-size`).
#[cfg(feature = "clap")]
pub fn parse_texel_size(s: &str) -> Result<(f32, f32), String> {
    let num = |p: &str| p.trim().parse::<f32>().map_err(|e| format!("{p:?}: {e}"));
    match s.split(',').collect::<Vec<_>>().as_slice() {
        [x] => num(x).map(|x| (x, x)),
        [x, y] => Ok((num(x)?, num(y)?)),
        _ => Err("expected SX or SX,SY".into()),
    }
}

/// Fields every job of a group of kinds writes among its own (a [`HeightSource`], or a plain
/// `input`), read out of a flat job by [`deserialize_flat`].
pub trait SharedFields: Sized {
    /// The fields as read so far.
    #[doc(hidden)]
    type Partial: Default;
    /// Their names in `pipeline.ron`.
    const NAMES: &'static [&'static str];
    /// Reads the value of field `key` (one of [`NAMES`](Self::NAMES)) from `map`.
    #[doc(hidden)]
    fn read<'de, A: MapAccess<'de>>(partial: &mut Self::Partial, key: &str, map: &mut A) -> Result<(), A::Error>;
    /// The fields, with defaults where they were left out.
    #[doc(hidden)]
    fn finish<E: de::Error>(partial: Self::Partial) -> Result<Self, E>;
}

/// Reads one value into `slot`, refusing a second.
fn set<'de, T: Deserialize<'de>, A: MapAccess<'de>>(
    slot: &mut Option<T>,
    key: &'static str,
    map: &mut A,
) -> Result<(), A::Error> {
    if slot.is_some() {
        return Err(de::Error::duplicate_field(key));
    }
    *slot = Some(map.next_value()?);
    Ok(())
}

/// A [`HeightSource`] being read, field by field.
#[derive(Default)]
#[doc(hidden)]
pub struct SourceFields {
    input: Option<PathBuf>,
    raw_size: Option<Option<(u32, u32)>>,
    channel: Option<Option<String>>,
    texel_size: Option<(f32, f32)>,
    height_scale: Option<f32>,
    height_offset: Option<f32>,
}

impl SharedFields for HeightSource {
    type Partial = SourceFields;
    const NAMES: &'static [&'static str] =
        &["input", "raw_size", "channel", "texel_size", "height_scale", "height_offset"];

    fn read<'de, A: MapAccess<'de>>(p: &mut SourceFields, key: &str, map: &mut A) -> Result<(), A::Error> {
        match key {
            "input" => set(&mut p.input, "input", map),
            "raw_size" => set(&mut p.raw_size, "raw_size", map),
            "channel" => set(&mut p.channel, "channel", map),
            "texel_size" => set(&mut p.texel_size, "texel_size", map),
            "height_scale" => set(&mut p.height_scale, "height_scale", map),
            _ => set(&mut p.height_offset, "height_offset", map),
        }
    }

    fn finish<E: de::Error>(p: SourceFields) -> Result<HeightSource, E> {
        let d = HeightSource::new(p.input.ok_or_else(|| E::missing_field("input"))?);
        Ok(HeightSource {
            raw_size: p.raw_size.unwrap_or(d.raw_size),
            channel: p.channel.unwrap_or(d.channel),
            texel_size: p.texel_size.unwrap_or(d.texel_size),
            height_scale: p.height_scale.unwrap_or(d.height_scale),
            height_offset: p.height_offset.unwrap_or(d.height_offset),
            ..d
        })
    }
}

/// A job's one input file, written `input: "…"`.
impl SharedFields for PathBuf {
    type Partial = Option<PathBuf>;
    const NAMES: &'static [&'static str] = &["input"];

    fn read<'de, A: MapAccess<'de>>(p: &mut Option<PathBuf>, _: &str, map: &mut A) -> Result<(), A::Error> {
        set(p, "input", map)
    }

    fn finish<E: de::Error>(p: Option<PathBuf>) -> Result<PathBuf, E> {
        p.ok_or_else(|| E::missing_field("input"))
    }
}

/// Deserializes a job written flat — `id`, the shared fields `F` and the job's own — into its
/// id, the shared fields and its own settings `S` (a struct that denies unknown fields, so a
/// typo is refused by name wherever it is written).
pub fn deserialize_flat<'de, D, F, S>(deserializer: D, name: &'static str) -> Result<(String, F, S), D::Error>
where
    D: Deserializer<'de>,
    F: SharedFields,
    S: Deserialize<'de>,
{
    struct Job<F, S>(PhantomData<(F, S)>);
    impl<'de, F: SharedFields, S: Deserialize<'de>> Visitor<'de> for Job<F, S> {
        type Value = (String, F, S);
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("a job's fields")
        }
        fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
            let (mut id, mut shared) = (None, F::Partial::default());
            let own = S::deserialize(Rest::<A, F> { map: &mut map, id: &mut id, shared: &mut shared })?;
            let id = id.ok_or_else(|| de::Error::missing_field("id"))?;
            Ok((id, F::finish(shared)?, own))
        }
    }
    deserializer.deserialize_struct(name, &[], Job(PhantomData))
}

/// The job's own fields of a map whose `id` and shared fields are taken out on the way, as a
/// deserializer of `S`.
struct Rest<'a, A, F: SharedFields> {
    map: &'a mut A,
    id: &'a mut Option<String>,
    shared: &'a mut F::Partial,
}

impl<'de, A: MapAccess<'de>, F: SharedFields> Deserializer<'de> for Rest<'_, A, F> {
    type Error = A::Error;
    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, A::Error> {
        visitor.visit_map(self)
    }
    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf option unit
        unit_struct newtype_struct seq tuple tuple_struct map struct enum identifier ignored_any
    }
}

impl<'de, A: MapAccess<'de>, F: SharedFields> MapAccess<'de> for Rest<'_, A, F> {
    type Error = A::Error;
    fn next_key_seed<K: DeserializeSeed<'de>>(&mut self, seed: K) -> Result<Option<K::Value>, A::Error> {
        while let Some(key) = self.map.next_key::<String>()? {
            if key == "id" {
                set(self.id, "id", self.map)?;
            } else if F::NAMES.contains(&key.as_str()) {
                F::read(self.shared, &key, self.map)?;
            } else {
                return seed.deserialize(key.into_deserializer()).map(Some);
            }
        }
        Ok(None)
    }
    fn next_value_seed<V: DeserializeSeed<'de>>(&mut self, seed: V) -> Result<V::Value, A::Error> {
        self.map.next_value_seed(seed)
    }
}
