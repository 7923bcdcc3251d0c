//! OpenEXR heightfields through the `exr` crate (f16, f32 or u32 samples, one channel of the
//! first layer).

use std::path::Path;

use exr::prelude::{FlatSamples, ReadChannels, ReadLayers, read};

use super::{LoadOptions, Samples, check_dimensions};
use crate::error::BakeError;

pub(super) fn load(path: &Path, options: &LoadOptions) -> Result<Samples, BakeError> {
    let bad = |e: exr::error::Error| BakeError::input(path, None, format!("cannot decode OpenEXR: {e}"));

    // Header first: size and channel choice before any pixel is decoded.
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(bad)?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| BakeError::input(path, Some("header".into()), "expected at least one layer"))?;
    let size = header.layer_size;
    check_dimensions(path, size.width() as u64, size.height() as u64, options.max_dimension)?;
    if header.deep {
        return Err(BakeError::input(path, Some("header".into()), "deep data is not a heightfield"));
    }
    let names: Vec<String> = header.channels.list.iter().map(|c| c.name.to_string()).collect();
    let chosen = match options.channel.as_deref() {
        Some(c) => names.iter().find(|n| n.as_str() == c).cloned().ok_or_else(|| {
            BakeError::input(
                path,
                Some("header".into()),
                format!("channel {c:?} is not in the file; it has {}", names.join(", ")),
            )
        })?,
        None => ["Y", "R"]
            .iter()
            .find_map(|want| names.iter().find(|n| n.as_str() == *want).cloned())
            .or_else(|| (names.len() == 1).then(|| names[0].clone()))
            .ok_or_else(|| {
                BakeError::input(
                    path,
                    Some("header".into()),
                    format!(
                        "expected a Y or R channel or a single channel, found {}; name the channel to take",
                        names.join(", ")
                    ),
                )
            })?,
    };

    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .non_parallel()
        .from_file(path)
        .map_err(bad)?;
    let layer = &image.layer_data;
    let channel = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == chosen)
        .ok_or_else(|| BakeError::input(path, None, format!("channel {chosen:?} vanished while decoding")))?;
    let values: Vec<f32> = match &channel.sample_data {
        FlatSamples::F16(v) => v.iter().map(|x| x.to_f32()).collect(),
        FlatSamples::F32(v) => v.clone(),
        FlatSamples::U32(v) => v.iter().map(|&x| x as f32).collect(),
    };
    let (w, h) = (layer.size.width() as u32, layer.size.height() as u32);
    if values.len() != w as usize * h as usize {
        return Err(BakeError::input(
            path,
            None,
            format!("expected {} samples, decoded {}", w as usize * h as usize, values.len()),
        ));
    }
    Ok(Samples { width: w, height: h, values, normalized: false, channel: chosen })
}
