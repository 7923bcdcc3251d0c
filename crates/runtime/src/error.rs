//! The one error type of hikage-runtime.

/// Everything that can go wrong loading a bundle onto a device.
#[derive(Debug, thiserror::Error)]
pub enum RuntimeError {
    /// Opening, reading or decoding the bundle failed (hash mismatch, bad KTX2, …).
    #[error(transparent)]
    Bundle(#[from] hikage_bundle::BundleError),
    /// The device cannot hold an asset (size above its limits, format not sampleable).
    #[error("asset `{asset}`: {message}")]
    Unsupported {
        /// The asset id.
        asset: String,
        /// What the device lacks.
        message: String,
    },
    /// An asset a component was given is missing from the uploaded bundle, or is not of the
    /// kind the component needs.
    #[error("asset `{asset}`: {message}")]
    Asset {
        /// The asset id.
        asset: String,
        /// What was expected and what was found.
        message: String,
    },
    /// wgpu reported a validation or out-of-memory error while uploading.
    #[error("asset `{asset}`: wgpu rejected the upload: {message}")]
    Wgpu {
        /// The asset id.
        asset: String,
        /// wgpu's message.
        message: String,
    },
}
