//! Image sequences: the files of a folder or a glob pattern, in name order, decoded to RGB8.

use std::path::{Path, PathBuf};

/// Why an image sequence cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum SequenceError {
    /// The folder cannot be listed.
    #[error("cannot list image folder {path}: {source}")]
    ListFolder {
        /// The folder.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The glob pattern is malformed.
    #[error("image pattern `{pattern}` is not a valid glob: {reason}")]
    Pattern {
        /// The pattern.
        pattern: String,
        /// What is wrong with it.
        reason: String,
    },
    /// Nothing matched.
    #[error(
        "no PNG or JPEG image at `{0}`: give a folder of images or a glob such as frames/*.png"
    )]
    NoImages(String),
    /// An image could not be read or decoded.
    #[error("cannot read image {path}: {reason}")]
    Image {
        /// The file.
        path: PathBuf,
        /// What the decoder said.
        reason: String,
    },
}

/// Whether a file name ends in `.png`, `.jpg` or `.jpeg` (any case).
#[must_use]
pub fn is_image_file(path: &Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| {
        ["png", "jpg", "jpeg"]
            .iter()
            .any(|x| e.eq_ignore_ascii_case(x))
    })
}

/// The images a source names: the PNG and JPEG files of a folder, or the files a glob
/// pattern matches, sorted by path.
///
/// # Errors
/// When the folder cannot be listed, the pattern is malformed, or nothing matches.
pub fn resolve(source: &str) -> Result<Vec<PathBuf>, SequenceError> {
    let path = Path::new(source);
    let mut files: Vec<PathBuf> = if path.is_dir() {
        std::fs::read_dir(path)
            .map_err(|source| SequenceError::ListFolder {
                path: path.to_path_buf(),
                source,
            })?
            .filter_map(|entry| entry.ok().map(|e| e.path()))
            .filter(|p| p.is_file() && is_image_file(p))
            .collect()
    } else {
        glob::glob(source)
            .map_err(|e| SequenceError::Pattern {
                pattern: source.to_owned(),
                reason: e.msg.to_owned(),
            })?
            .filter_map(Result::ok)
            .filter(|p| p.is_file())
            .collect()
    };
    files.sort();
    if files.is_empty() {
        return Err(SequenceError::NoImages(source.to_owned()));
    }
    Ok(files)
}

/// An image decoded to tightly packed RGB8.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RgbImageData {
    /// Width, in px.
    pub width_px: u32,
    /// Height, in px.
    pub height_px: u32,
    /// `width * height * 3` bytes, rows top first.
    pub rgb: Vec<u8>,
}

/// Reads and decodes one PNG or JPEG file to RGB8.
///
/// # Errors
/// When the file cannot be read or decoded.
pub fn load_rgb(path: &Path) -> Result<RgbImageData, SequenceError> {
    let image = image::ImageReader::open(path)
        .and_then(image::ImageReader::with_guessed_format)
        .map_err(|e| SequenceError::Image {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })?
        .decode()
        .map_err(|e| SequenceError::Image {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })?
        .into_rgb8();
    let (width_px, height_px) = image.dimensions();
    Ok(RgbImageData {
        width_px,
        height_px,
        rgb: image.into_raw(),
    })
}

/// A sequence of image files played in order, once or in a loop.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ImageSequence {
    files: Vec<PathBuf>,
    next: usize,
    looping: bool,
}

impl ImageSequence {
    /// The sequence of `files`, from the first.
    #[must_use]
    pub fn new(files: Vec<PathBuf>, looping: bool) -> Self {
        Self {
            files,
            next: 0,
            looping,
        }
    }

    /// The files.
    #[must_use]
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }

    /// The next file to show, or `None` at the end of a sequence that does not loop.
    pub fn next_file(&mut self) -> Option<&Path> {
        if self.next >= self.files.len() {
            if !self.looping || self.files.is_empty() {
                return None;
            }
            self.next = 0;
        }
        let file = self.files.get(self.next)?;
        self.next += 1;
        Some(file)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(seq: &mut ImageSequence, n: usize) -> Vec<String> {
        (0..n)
            .map(|_| {
                seq.next_file()
                    .map_or("end".to_owned(), |p| p.display().to_string())
            })
            .collect()
    }

    #[test]
    fn sequences_play_once_or_loop() {
        let files = vec![PathBuf::from("a.png"), PathBuf::from("b.png")];
        let mut once = ImageSequence::new(files.clone(), false);
        assert_eq!(names(&mut once, 3), ["a.png", "b.png", "end"]);
        let mut looping = ImageSequence::new(files, true);
        assert_eq!(
            names(&mut looping, 5),
            ["a.png", "b.png", "a.png", "b.png", "a.png"]
        );
        assert_eq!(names(&mut ImageSequence::new(vec![], true), 1), ["end"]);
    }

    #[test]
    fn image_files_are_recognised_by_extension() {
        for (name, expected) in [
            ("x.png", true),
            ("x.JPG", true),
            ("x.jpeg", true),
            ("x.txt", false),
            ("png", false),
        ] {
            assert_eq!(is_image_file(Path::new(name)), expected, "{name}");
        }
    }
}
