//! PNG output shared by the examples: best compression, since the images are committed.

/// Writes `image` to `path` as a maximally compressed PNG.
pub fn save(image: &image::RgbaImage, path: &std::path::Path) -> Result<(), Box<dyn std::error::Error>> {
    let file = std::io::BufWriter::new(std::fs::File::create(path)?);
    let encoder = image::codecs::png::PngEncoder::new_with_quality(
        file,
        image::codecs::png::CompressionType::Best,
        image::codecs::png::FilterType::Adaptive,
    );
    image.write_with_encoder(encoder)?;
    Ok(())
}
