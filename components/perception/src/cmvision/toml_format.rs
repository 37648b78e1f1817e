//! The TOML colour file format: the same content as Player's, with names for the fields.
//!
//! ```toml
//! min_area_px = 20            # optional, default 1
//!
//! [[color]]
//! name = "Red"
//! display_rgb = [255, 0, 0]   # optional, default [255, 255, 255]
//! merge_density = 0.0         # optional, default 0 (no merging)
//! expected_regions = 10       # optional, default 0
//! y = [25, 164]               # inclusive YUV ranges, 0..=255, low first
//! u = [80, 120]
//! v = [150, 240]
//! ```
//!
//! Unknown keys are errors (a misspelt `merge_densty` must not be silently ignored).

use serde::Deserialize;
use toml::Spanned;

use super::config::{
    ChannelRange, ColorClass, ColorConfig, ColorFileError, ColorFileProblem, MAX_COLORS,
    line_column,
};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    #[serde(default = "one")]
    min_area_px: u32,
    #[serde(default)]
    color: Vec<Spanned<Color>>,
}

fn one() -> u32 {
    1
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Color {
    name: String,
    #[serde(default = "white")]
    display_rgb: [u8; 3],
    #[serde(default)]
    merge_density: f64,
    #[serde(default)]
    expected_regions: u32,
    y: Spanned<[u8; 2]>,
    u: Spanned<[u8; 2]>,
    v: Spanned<[u8; 2]>,
}

fn white() -> [u8; 3] {
    [255, 255, 255]
}

/// Parses the TOML colour format; `source_name` labels errors.
pub(super) fn parse(text: &str, source_name: &str) -> Result<ColorConfig, ColorFileError> {
    let invalid = |offset: usize, problem| {
        let (line, column) = line_column(text, offset);
        ColorFileError::Invalid {
            source_name: source_name.to_owned(),
            line,
            column,
            problem,
        }
    };
    let file: File = toml::from_str(text).map_err(|e| {
        let offset = e.span().map_or(0, |span| span.start);
        invalid(
            offset,
            ColorFileProblem::Toml(e.message().trim_end().to_owned()),
        )
    })?;
    if file.color.is_empty() {
        return Err(invalid(text.len(), ColorFileProblem::NoColors));
    }
    if let Some(extra) = file.color.get(MAX_COLORS) {
        return Err(invalid(extra.span().start, ColorFileProblem::TooManyColors));
    }
    let mut colors = Vec::with_capacity(file.color.len());
    for spanned in file.color {
        let color_start = spanned.span().start;
        let color = spanned.into_inner();
        if !(color.merge_density >= 0.0 && color.merge_density.is_finite()) {
            return Err(invalid(
                color_start,
                ColorFileProblem::BadMergeDensity(color.merge_density.to_string()),
            ));
        }
        let range = |channel: char, spanned: &Spanned<[u8; 2]>| {
            let [lo, hi] = *spanned.get_ref();
            if lo > hi {
                let problem = ColorFileProblem::ReversedRange {
                    channel,
                    lo: i64::from(lo),
                    hi: i64::from(hi),
                };
                return Err(invalid(spanned.span().start, problem));
            }
            Ok(ChannelRange { lo, hi })
        };
        colors.push(ColorClass {
            y: range('Y', &color.y)?,
            u: range('U', &color.u)?,
            v: range('V', &color.v)?,
            name: color.name,
            display_rgb: color.display_rgb,
            merge_density: color.merge_density,
            expected_regions: color.expected_regions,
        });
    }
    Ok(ColorConfig {
        colors,
        min_area_px: file.min_area_px,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_err(text: &str, expected_message: &str) {
        match parse(text, "c.toml") {
            Ok(config) => panic!("parsed {config:?}, expected error {expected_message}"),
            Err(e) => assert_eq!(e.to_string(), expected_message),
        }
    }

    #[test]
    fn a_full_colour_table_parses_with_defaults() {
        let text = "min_area_px = 20\n[[color]]\nname = \"Red\"\ny = [25, 164]\nu = [80, 120]\nv = [150, 240]\n\n[[color]]\nname = \"Blue\"\ndisplay_rgb = [0, 0, 255]\nmerge_density = 0.5\nexpected_regions = 3\ny = [0, 255]\nu = [150, 255]\nv = [0, 120]\n";
        let config = parse(text, "c.toml").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(config.min_area_px, 20);
        assert_eq!(config.colors.len(), 2);
        assert_eq!(config.colors[0].display_rgb, [255, 255, 255]);
        assert_eq!(config.colors[0].v, ChannelRange { lo: 150, hi: 240 });
        assert_eq!(config.colors[1].expected_regions, 3);
    }

    #[test]
    fn errors_carry_the_line_of_the_offending_value() {
        check_err(
            "[[color]]\nname = \"Red\"\ny = [25, 164]\nu = [120, 80]\nv = [150, 240]\n",
            "c.toml:4:5: U range 120:80 is reversed: write the low value first",
        );
        let message = parse(
            "[[color]]\nname = \"Red\"\ny = [25, 300]\nu = [0, 1]\nv = [0, 1]\n",
            "c.toml",
        )
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
        assert!(message.starts_with("c.toml:3:"), "{message}");
        let message = parse("[[color]]\nname = \"Red\"\nmerge_densty = 0.5\n", "c.toml")
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            message.starts_with("c.toml:3:1: unknown field `merge_densty`"),
            "{message}"
        );
        check_err(
            "min_area_px = 3\n",
            "c.toml:2:1: no colours defined: add a [Colors] section (or [[color]] tables in TOML)",
        );
    }
}
