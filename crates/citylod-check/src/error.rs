//! The one error type of citylod-check. Every variant carries the context a user needs to act:
//! which input was bad and why, or which package to install when there is no GPU adapter.

/// Errors of the checker. Bad inputs are reported here, never as a panic.
#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    /// No Vulkan adapter (GPU or Mesa lavapipe) could be opened.
    #[error(
        "no Vulkan adapter found ({detail}); on a machine without a GPU install Mesa's software \
         Vulkan driver lavapipe: `apt-get install mesa-vulkan-drivers libvulkan1`"
    )]
    NoAdapter { detail: String },
    /// The adapter was found but refused to open a device.
    #[error("could not open a device on adapter {adapter}: {detail}")]
    Device { adapter: String, detail: String },
    /// wgpu reported a validation or out-of-memory error while rendering.
    #[error("rendering failed during {stage}: {detail}")]
    Render { stage: &'static str, detail: String },
    /// A camera parameter is out of range or not finite.
    #[error("invalid camera: {0}")]
    Camera(String),
    /// A mesh handed to the scene is malformed.
    #[error("invalid mesh for feature {feature_id}: {detail}")]
    Mesh { feature_id: u32, detail: String },
    /// An image has an unusable size, or two images that must match do not.
    #[error("invalid image: {0}")]
    Image(String),
    /// Writing a PNG failed.
    #[error("cannot write {path}: {detail}")]
    Png { path: String, detail: String },
}
