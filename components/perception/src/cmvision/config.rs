//! Colour classes: what CMVision looks for, read from Player colour files or TOML.

use std::path::{Path, PathBuf};

use super::{player_format, toml_format};

/// The most colour classes CMVision classifies at once: one bit each in a `u32` mask.
pub const MAX_COLORS: usize = 32;

/// An inclusive range of one YUV channel (`lo..=hi`); `lo > hi` matches nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ChannelRange {
    /// Lowest value in the class.
    pub lo: u8,
    /// Highest value in the class.
    pub hi: u8,
}

impl ChannelRange {
    /// Whether `value` lies in the range.
    #[must_use]
    pub fn contains(self, value: u8) -> bool {
        self.lo <= value && value <= self.hi
    }
}

/// One colour class: a box in YUV space plus what Player's file says about it.
#[derive(Debug, Clone, PartialEq)]
pub struct ColorClass {
    /// Name from the file (`Ball`, `Red`); `color<N>` when the file gives none.
    pub name: String,
    /// The colour to draw this class's blobs with (not used for classification).
    pub display_rgb: [u8; 3],
    /// Density threshold for merging two regions of this class: they merge when
    /// `(area_a + area_b) / area of their union box` exceeds it; 0 (Player's usual value)
    /// or less turns merging off for the class.
    pub merge_density: f64,
    /// How many regions the file expects (Player's `expected_regions`; informative only).
    pub expected_regions: u32,
    /// Range of Y (luma).
    pub y: ChannelRange,
    /// Range of U (blue-difference chroma).
    pub u: ChannelRange,
    /// Range of V (red-difference chroma).
    pub v: ChannelRange,
}

impl ColorClass {
    /// Whether a YUV pixel belongs to this class.
    #[must_use]
    pub fn contains_yuv(&self, [y, u, v]: [u8; 3]) -> bool {
        self.y.contains(y) && self.u.contains(u) && self.v.contains(v)
    }
}

/// The colour classes of one CMVision instance, in file order (index = colour id).
#[derive(Debug, Clone, PartialEq)]
pub struct ColorConfig {
    /// The classes; at most [`MAX_COLORS`].
    pub colors: Vec<ColorClass>,
    /// Regions smaller than this many pixels are dropped (Player files do not set it: 1).
    pub min_area_px: u32,
}

/// Why a colour file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ColorFileError {
    /// The file could not be read (missing, unreadable, not UTF-8).
    #[error("cannot read colour file {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The text is not a valid colour file.
    #[error("{source_name}:{line}:{column}: {problem}")]
    Invalid {
        /// File name (or another label for text that did not come from a file).
        source_name: String,
        /// 1-based line of the problem.
        line: usize,
        /// 1-based column (in characters) of the problem.
        column: usize,
        /// What is wrong.
        problem: ColorFileProblem,
    },
}

/// What is wrong at one place of a colour file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ColorFileProblem {
    /// A token of the wrong kind.
    #[error("expected {expected}, found {found}")]
    Expected {
        /// What the format needs here.
        expected: &'static str,
        /// What the file has instead (quoted text or `end of line`).
        found: String,
    },
    /// A number outside what its field allows.
    #[error("{what} {value} is out of range {min}..={max}")]
    OutOfRange {
        /// The field.
        what: &'static str,
        /// The value in the file.
        value: String,
        /// Smallest allowed value.
        min: i64,
        /// Largest allowed value.
        max: i64,
    },
    /// A merge density that is negative or not a number.
    #[error("merge density {0} must be a number of at least 0 (0 turns merging off)")]
    BadMergeDensity(String),
    /// A `[Section]` header the format does not have.
    #[error("unknown section [{0}]: use [Colors], [Thresholds] or [Options]")]
    UnknownSection(String),
    /// An `[Options]` line with a key the format does not have.
    #[error("unknown option `{0}`: the only option is min_area_px")]
    UnknownOption(String),
    /// A section given twice.
    #[error("section [{0}] appears twice: keep one")]
    DuplicateSection(String),
    /// A content line before any section header.
    #[error("line outside a section: start the file with [Colors]")]
    OutsideSection,
    /// More than [`MAX_COLORS`] classes.
    #[error("more than {MAX_COLORS} colours: CMVision classifies at most {MAX_COLORS} at once")]
    TooManyColors,
    /// A `[Thresholds]` line beyond the number of `[Colors]` lines.
    #[error("threshold {index} has no colour: [Colors] lists {colors}")]
    ThresholdWithoutColor {
        /// 1-based number of the threshold line.
        index: usize,
        /// Number of colours.
        colors: usize,
    },
    /// Fewer threshold lines than colours.
    #[error("{colors} colours but {thresholds} thresholds: add one threshold line per colour")]
    MissingThresholds {
        /// Number of colours.
        colors: usize,
        /// Number of threshold lines.
        thresholds: usize,
    },
    /// A file without colours.
    #[error("no colours defined: add a [Colors] section (or [[color]] tables in TOML)")]
    NoColors,
    /// A range whose low end is above its high end.
    #[error("{channel} range {lo}:{hi} is reversed: write the low value first")]
    ReversedRange {
        /// `Y`, `U` or `V`.
        channel: char,
        /// Low end as written.
        lo: i64,
        /// High end as written.
        hi: i64,
    },
    /// A TOML syntax or schema error, as the TOML parser words it.
    #[error("{0}")]
    Toml(String),
}

impl ColorConfig {
    /// Reads a colour file: TOML when the name ends in `.toml`, Player's format otherwise.
    ///
    /// # Errors
    /// [`ColorFileError::Read`] when the file cannot be read as UTF-8 text,
    /// [`ColorFileError::Invalid`] (with line and column) when its content is wrong.
    pub fn load(path: &Path) -> Result<Self, ColorFileError> {
        let text = std::fs::read_to_string(path).map_err(|source| ColorFileError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let name = path.display().to_string();
        if path
            .extension()
            .is_some_and(|ext| ext.eq_ignore_ascii_case("toml"))
        {
            Self::from_toml_str(&text, &name)
        } else {
            Self::from_player_str(&text, &name)
        }
    }

    /// Parses Player's CMVision colour file format (see [`player_format`]).
    /// `source_name` labels the errors (usually the file name).
    ///
    /// # Errors
    /// [`ColorFileError::Invalid`] naming the line, column and problem.
    pub fn from_player_str(text: &str, source_name: &str) -> Result<Self, ColorFileError> {
        player_format::parse(text, source_name)
    }

    /// The configuration as a Player colour file (with `[Options]` when `min_area_px` is
    /// not 1), `comment`'s lines first as `#` comments: [`ColorConfig::from_player_str`]
    /// reads it back to the same configuration.
    #[must_use]
    pub fn to_player_string(&self, comment: &str) -> String {
        player_format::write(self, comment)
    }

    /// Parses the TOML colour file format (see [`toml_format`]).
    ///
    /// # Errors
    /// [`ColorFileError::Invalid`] naming the line, column and problem.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Self, ColorFileError> {
        toml_format::parse(text, source_name)
    }

    /// The class mask of a YUV pixel computed straight from the ranges (bit k: colour k),
    /// the slow reference that the classifier's tables must agree with.
    #[must_use]
    pub fn class_mask_yuv(&self, yuv: [u8; 3]) -> u32 {
        self.colors
            .iter()
            .take(MAX_COLORS)
            .enumerate()
            .filter(|(_, class)| class.contains_yuv(yuv))
            .fold(0, |mask, (k, _)| mask | (1 << k))
    }
}

pub(super) use lewis_stdx::line_column;
