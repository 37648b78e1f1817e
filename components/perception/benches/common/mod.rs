//! What the perception benchmarks share: the photos of `../shared/data/images` as the
//! camera's frames.

use std::path::{Path, PathBuf};

/// The camera's frame width.
pub const WIDTH: u32 = 640;
/// The camera's frame height.
pub const HEIGHT: u32 = 480;

/// `relative` from the repository's root.
pub fn repository_path(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(relative)
}

/// A photo of ../shared/data/images as 640x480 RGB8 (resized with a triangle filter when it
/// has another size: fruits.jpg is 512x480).
pub fn load_frame(name: &str) -> Result<Vec<u8>, String> {
    let path = repository_path("../shared/data/images").join(name);
    let photo = image::open(&path)
        .map_err(|e| {
            format!(
                "{}: {e} (the benchmark reads the shared data)",
                path.display()
            )
        })?
        .to_rgb8();
    if photo.dimensions() == (WIDTH, HEIGHT) {
        return Ok(photo.into_raw());
    }
    Ok(
        image::imageops::resize(&photo, WIDTH, HEIGHT, image::imageops::FilterType::Triangle)
            .into_raw(),
    )
}
