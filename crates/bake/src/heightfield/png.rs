//! PNG heightfields through the `image` crate (8- and 16-bit, grayscale or a named colour
//! channel).

use std::path::Path;

use image::{DynamicImage, ImageDecoder};

use super::{LoadOptions, Samples, check_dimensions};
use crate::error::BakeError;

pub(super) fn load(path: &Path, options: &LoadOptions) -> Result<Samples, BakeError> {
    let bad = |e: image::ImageError| BakeError::input(path, None, format!("cannot decode PNG: {e}"));
    // The size sits at a fixed place (IHDR, bytes 16..24): check it before the decoder reads on.
    check_ihdr(path, options)?;
    let reader = image::ImageReader::open(path)
        .map_err(|e| BakeError::io(path, e))?
        .with_guessed_format()
        .map_err(|e| BakeError::io(path, e))?;
    let mut reader = reader;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(options.max_dimension);
    limits.max_image_height = Some(options.max_dimension);
    reader.limits(limits);
    let decoder = reader.into_decoder().map_err(bad)?;
    let (w, h) = decoder.dimensions();
    check_dimensions(path, w as u64, h as u64, options.max_dimension)?;
    let color = decoder.color_type();
    let gray =
        matches!(color, image::ColorType::L8 | image::ColorType::L16 | image::ColorType::La8 | image::ColorType::La16);
    let channel_index = match (options.channel.as_deref(), gray) {
        (None, true) => 0,
        (None, false) => {
            return Err(BakeError::input(
                path,
                None,
                format!("expected a grayscale image, found {color:?}; name a channel (R, G or B) to take one"),
            ));
        }
        (Some(c), _) => {
            let names: &[&str] = if gray { &["Y", "A"] } else { &["R", "G", "B", "A"] };
            let upper = c.to_ascii_uppercase();
            let upper = if gray && (upper == "L" || upper == "LUMA") { "Y".to_string() } else { upper };
            match names.iter().position(|n| *n == upper) {
                Some(i) if i < color.channel_count() as usize => i,
                _ => {
                    return Err(BakeError::input(
                        path,
                        None,
                        format!(
                            "channel {c:?} is not in this {color:?} image; it has {}",
                            names[..color.channel_count() as usize].join(", ")
                        ),
                    ));
                }
            }
        }
    };
    let image = DynamicImage::from_decoder(decoder).map_err(bad)?;
    let sixteen = color.bytes_per_pixel() / color.channel_count() == 2;
    let channels = color.channel_count() as usize;
    let values: Vec<f32> = if sixteen {
        let buf: Vec<u16> = match image {
            DynamicImage::ImageLuma16(b) => b.into_raw(),
            DynamicImage::ImageLumaA16(b) => b.into_raw(),
            DynamicImage::ImageRgb16(b) => b.into_raw(),
            DynamicImage::ImageRgba16(b) => b.into_raw(),
            other => other.to_rgba16().into_raw(),
        };
        buf.chunks_exact(channels).map(|p| p[channel_index] as f32 / 65535.0).collect()
    } else {
        let buf: Vec<u8> = match image {
            DynamicImage::ImageLuma8(b) => b.into_raw(),
            DynamicImage::ImageLumaA8(b) => b.into_raw(),
            DynamicImage::ImageRgb8(b) => b.into_raw(),
            DynamicImage::ImageRgba8(b) => b.into_raw(),
            other => other.to_rgba8().into_raw(),
        };
        buf.chunks_exact(channels).map(|p| p[channel_index] as f32 / 255.0).collect()
    };
    let channel = if gray && channel_index == 0 {
        "luma".to_string()
    } else {
        options.channel.clone().unwrap_or_default().to_ascii_uppercase()
    };
    Ok(Samples { width: w, height: h, values, normalized: true, channel })
}

/// Reads the IHDR chunk's width and height (big-endian at bytes 16 and 20) and checks them.
fn check_ihdr(path: &Path, options: &LoadOptions) -> Result<(), BakeError> {
    use std::io::Read;
    let mut head = [0u8; 24];
    let mut f = std::fs::File::open(path).map_err(|e| BakeError::io(path, e))?;
    if f.read_exact(&mut head).is_err() || &head[12..16] != b"IHDR" {
        return Err(BakeError::input(path, Some("byte 12".into()), "expected the PNG IHDR chunk"));
    }
    let w = u32::from_be_bytes([head[16], head[17], head[18], head[19]]);
    let h = u32::from_be_bytes([head[20], head[21], head[22], head[23]]);
    check_dimensions(path, w as u64, h as u64, options.max_dimension)
}
