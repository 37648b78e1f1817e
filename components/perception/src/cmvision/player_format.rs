//! Player's CMVision colour file format.
//!
//! ```text
//! [Colors]
//! (255,128,  0) 0.000000 10 Ball      # (R,G,B) merge_density [expected_regions] [name]
//! [Thresholds]
//! ( 12:153, 99:127,143:168)           # (Ylo:Yhi,Ulo:Uhi,Vlo:Vhi), one line per colour, same order
//! ```
//!
//! Beyond what Player's own reader accepts, this one is tolerant of whitespace anywhere
//! between tokens, `#` comments, blank lines, CRLF, a missing `expected_regions` (the files
//! Player shipped have both forms) and a missing name (`color<N>`, 0-based). Threshold values
//! outside 0..=255 are clamped as CMVision clamped them (`( 85:190, 82:189,141:269)` is in
//! Player's own file); a range wholly outside 0..=255 matches nothing.
//!
//! One extension: an `[Options]` section with `min_area_px = N`, the smallest blob of the
//! file's classes (Player's format has no field for it: its driver took it from its own
//! configuration). CMVision's reader skips the lines of a section it does not know, so a
//! file with it still loads in Player.
//!
//! ```text
//! [Options]
//! min_area_px = 700
//! ```

use super::config::{
    ChannelRange, ColorClass, ColorConfig, ColorFileError, ColorFileProblem, MAX_COLORS,
};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Section {
    Colors,
    Thresholds,
    Options,
}

impl Section {
    fn name(self) -> &'static str {
        match self {
            Self::Colors => "Colors",
            Self::Thresholds => "Thresholds",
            Self::Options => "Options",
        }
    }
}

#[derive(Clone, Copy)]
struct Place {
    line: usize,
    column: usize,
}

/// The text of a Player colour file for `config`, which [`parse`] reads back to the same
/// configuration; every line of `comment` goes first, as a `#` comment.
pub(super) fn write(config: &ColorConfig, comment: &str) -> String {
    use std::fmt::Write as _;
    let mut text = String::new();
    for line in comment.lines() {
        let _ = writeln!(text, "# {line}");
    }
    if !comment.is_empty() {
        text.push('\n');
    }
    text.push_str("[Colors]\n");
    for class in &config.colors {
        let [r, g, b] = class.display_rgb;
        let _ = writeln!(
            text,
            "({r:3},{g:3},{b:3}) {:.6} {} {}",
            class.merge_density, class.expected_regions, class.name
        );
    }
    text.push_str("\n[Thresholds]\n");
    // A range that matches nothing (lo > hi) is written outside 0..=255, which reads back
    // as matching nothing; written reversed it would not read at all.
    let range = |r: ChannelRange| {
        if r.lo > r.hi {
            "256:256".to_owned()
        } else {
            format!("{:3}:{:3}", r.lo, r.hi)
        }
    };
    for class in &config.colors {
        let _ = writeln!(
            text,
            "({},{},{})",
            range(class.y),
            range(class.u),
            range(class.v)
        );
    }
    if config.min_area_px != 1 {
        let _ = write!(text, "\n[Options]\nmin_area_px = {}\n", config.min_area_px);
    }
    text
}

/// Parses the text of a Player colour file; `source_name` labels errors.
pub(super) fn parse(text: &str, source_name: &str) -> Result<ColorConfig, ColorFileError> {
    let invalid = |place: Place, problem| ColorFileError::Invalid {
        source_name: source_name.to_owned(),
        line: place.line,
        column: place.column,
        problem,
    };
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut section = None;
    let mut seen = [false; 3];
    let mut min_area_px = 1;
    let mut thresholds_header_line = 0;
    let mut colors: Vec<ColorClass> = Vec::new();
    let mut thresholds = 0usize;
    for (index, raw_line) in text.lines().enumerate() {
        let line_no = index + 1;
        let content = raw_line.split('#').next().unwrap_or("");
        let mut cursor = Cursor::new(content, line_no);
        cursor.skip_whitespace();
        if cursor.at_end() {
            continue;
        }
        if cursor.peek() == Some('[') {
            let found = parse_header(&mut cursor).map_err(|(p, e)| invalid(p, e))?;
            let slot = found as usize;
            if seen[slot] {
                return Err(invalid(
                    Place {
                        line: line_no,
                        column: 1,
                    },
                    ColorFileProblem::DuplicateSection(found.name().to_owned()),
                ));
            }
            seen[slot] = true;
            if found == Section::Thresholds {
                thresholds_header_line = line_no;
            }
            section = Some(found);
            continue;
        }
        match section {
            None => {
                return Err(invalid(cursor.place(), ColorFileProblem::OutsideSection));
            }
            Some(Section::Colors) => {
                if colors.len() == MAX_COLORS {
                    return Err(invalid(cursor.place(), ColorFileProblem::TooManyColors));
                }
                let class =
                    parse_color_line(&mut cursor, colors.len()).map_err(|(p, e)| invalid(p, e))?;
                colors.push(class);
            }
            Some(Section::Thresholds) => {
                let place = cursor.place();
                let Some(class) = colors.get_mut(thresholds) else {
                    return Err(invalid(
                        place,
                        ColorFileProblem::ThresholdWithoutColor {
                            index: thresholds + 1,
                            colors: colors.len(),
                        },
                    ));
                };
                let [y, u, v] =
                    parse_threshold_line(&mut cursor).map_err(|(p, e)| invalid(p, e))?;
                (class.y, class.u, class.v) = (y, u, v);
                thresholds += 1;
            }
            Some(Section::Options) => {
                min_area_px = parse_option_line(&mut cursor).map_err(|(p, e)| invalid(p, e))?;
            }
        }
    }
    if colors.is_empty() {
        let line = text.lines().count().max(1);
        return Err(invalid(
            Place { line, column: 1 },
            ColorFileProblem::NoColors,
        ));
    }
    if thresholds < colors.len() {
        let line = if thresholds_header_line == 0 {
            text.lines().count().max(1)
        } else {
            thresholds_header_line
        };
        return Err(invalid(
            Place { line, column: 1 },
            ColorFileProblem::MissingThresholds {
                colors: colors.len(),
                thresholds,
            },
        ));
    }
    Ok(ColorConfig {
        colors,
        min_area_px,
    })
}

/// `min_area_px = N`, the one option there is.
fn parse_option_line(cursor: &mut Cursor<'_>) -> LineResult<u32> {
    cursor.skip_whitespace();
    let key_place = cursor.place();
    let key = cursor.take_while(|c| c.is_ascii_alphanumeric() || c == '_');
    if key != "min_area_px" {
        return Err((key_place, ColorFileProblem::UnknownOption(key.to_owned())));
    }
    cursor.expect('=', "= after the option's name")?;
    let value = cursor.integer_in("min_area_px", 0, i64::from(u32::MAX))?;
    cursor.expect_end()?;
    // integer_in checked 0..=u32::MAX.
    Ok(u32::try_from(value).unwrap_or(u32::MAX))
}

type LineResult<T> = Result<T, (Place, ColorFileProblem)>;

fn parse_header(cursor: &mut Cursor<'_>) -> LineResult<Section> {
    cursor.expect('[', "[")?;
    let name_place = cursor.place();
    let name = cursor.take_while(|c| c != ']').trim();
    cursor.expect(']', "] to close the section name")?;
    cursor.expect_end()?;
    match name.to_ascii_lowercase().as_str() {
        "colors" | "colours" => Ok(Section::Colors),
        "thresholds" => Ok(Section::Thresholds),
        "options" => Ok(Section::Options),
        _ => Err((
            name_place,
            ColorFileProblem::UnknownSection(name.to_owned()),
        )),
    }
}

fn parse_color_line(cursor: &mut Cursor<'_>, index: usize) -> LineResult<ColorClass> {
    cursor.expect('(', "( to open the colour (R,G,B)")?;
    let r = cursor.integer_in("red", 0, 255)?;
    cursor.expect(',', ", between colour components")?;
    let g = cursor.integer_in("green", 0, 255)?;
    cursor.expect(',', ", between colour components")?;
    let b = cursor.integer_in("blue", 0, 255)?;
    cursor.expect(')', ") to close the colour")?;
    cursor.skip_whitespace();
    let merge_place = cursor.place();
    let merge_text = cursor.token();
    if merge_text.is_empty() {
        return Err((
            merge_place,
            ColorFileProblem::Expected {
                expected: "a merge density",
                found: "end of line".into(),
            },
        ));
    }
    let merge_density = match merge_text.parse::<f64>() {
        Ok(value) if value >= 0.0 && value.is_finite() => value,
        _ => {
            return Err((
                merge_place,
                ColorFileProblem::BadMergeDensity(merge_text.to_owned()),
            ));
        }
    };
    cursor.skip_whitespace();
    let mut expected_regions = 0;
    let count_place = cursor.place();
    let rest = cursor.rest().trim_end();
    let first = rest.split_whitespace().next().unwrap_or("");
    let name = if !first.is_empty() && first.bytes().all(|c| c.is_ascii_digit()) {
        expected_regions = first.parse::<u32>().map_err(|_| {
            (
                count_place,
                ColorFileProblem::OutOfRange {
                    what: "expected regions",
                    value: first.to_owned(),
                    min: 0,
                    max: i64::from(u32::MAX),
                },
            )
        })?;
        rest.get(first.len()..).unwrap_or("").trim()
    } else {
        rest
    };
    let name = if name.is_empty() {
        format!("color{index}")
    } else {
        name.to_owned()
    };
    let nothing = ChannelRange { lo: 1, hi: 0 };
    // The u8 casts are exact: integer_in checked 0..=255.
    Ok(ColorClass {
        name,
        display_rgb: [r as u8, g as u8, b as u8],
        merge_density,
        expected_regions,
        y: nothing,
        u: nothing,
        v: nothing,
    })
}

fn parse_threshold_line(cursor: &mut Cursor<'_>) -> LineResult<[ChannelRange; 3]> {
    cursor.expect('(', "( to open the thresholds (Ylo:Yhi,Ulo:Uhi,Vlo:Vhi)")?;
    let mut ranges = [ChannelRange { lo: 0, hi: 0 }; 3];
    for (i, (range, channel)) in ranges.iter_mut().zip(['Y', 'U', 'V']).enumerate() {
        if i > 0 {
            cursor.expect(',', ", between channel ranges")?;
        }
        let lo_place = cursor.place_after_whitespace();
        let lo = cursor.integer_in("threshold", i64::from(i32::MIN), i64::from(i32::MAX))?;
        cursor.expect(':', ": between the low and high threshold")?;
        let hi = cursor.integer_in("threshold", i64::from(i32::MIN), i64::from(i32::MAX))?;
        if lo > hi {
            return Err((
                lo_place,
                ColorFileProblem::ReversedRange { channel, lo, hi },
            ));
        }
        *range = clamp_range(lo, hi);
    }
    cursor.expect(')', ") to close the thresholds")?;
    cursor.expect_end()?;
    Ok(ranges)
}

/// CMVision's clamping of a threshold range to the byte values a channel can take.
fn clamp_range(lo: i64, hi: i64) -> ChannelRange {
    if hi < 0 || lo > 255 {
        return ChannelRange { lo: 1, hi: 0 };
    }
    // Both clamped into 0..=255: the casts are exact.
    ChannelRange {
        lo: lo.clamp(0, 255) as u8,
        hi: hi.clamp(0, 255) as u8,
    }
}

/// A position in one line, counting columns in characters for the messages.
struct Cursor<'a> {
    text: &'a str,
    pos: usize,
    line: usize,
}

impl<'a> Cursor<'a> {
    fn new(text: &'a str, line: usize) -> Self {
        Self { text, pos: 0, line }
    }

    fn rest(&self) -> &'a str {
        self.text.get(self.pos..).unwrap_or("")
    }

    fn peek(&self) -> Option<char> {
        self.rest().chars().next()
    }

    fn at_end(&self) -> bool {
        self.rest().is_empty()
    }

    fn place(&self) -> Place {
        let column = self.text.get(..self.pos).map_or(0, |s| s.chars().count()) + 1;
        Place {
            line: self.line,
            column,
        }
    }

    fn place_after_whitespace(&mut self) -> Place {
        self.skip_whitespace();
        self.place()
    }

    fn take_while(&mut self, keep: impl Fn(char) -> bool) -> &'a str {
        let rest = self.rest();
        let len = rest.find(|c: char| !keep(c)).unwrap_or(rest.len());
        self.pos += len;
        rest.get(..len).unwrap_or("")
    }

    fn skip_whitespace(&mut self) {
        self.take_while(char::is_whitespace);
    }

    fn token(&mut self) -> &'a str {
        self.take_while(|c| !c.is_whitespace())
    }

    /// What the next token is, for "expected X, found Y".
    fn found(&self) -> String {
        let rest = self.rest();
        match rest.chars().next() {
            None => "end of line".to_owned(),
            Some(c) if c.is_ascii_punctuation() => format!("'{c}'"),
            Some(_) => {
                let word: String = rest
                    .chars()
                    .take_while(|c| !c.is_whitespace() && !c.is_ascii_punctuation())
                    .take(20)
                    .collect();
                format!("'{word}'")
            }
        }
    }

    fn expect(&mut self, wanted: char, expected: &'static str) -> LineResult<()> {
        self.skip_whitespace();
        if self.peek() == Some(wanted) {
            self.pos += wanted.len_utf8();
            Ok(())
        } else {
            Err((
                self.place(),
                ColorFileProblem::Expected {
                    expected,
                    found: self.found(),
                },
            ))
        }
    }

    fn expect_end(&mut self) -> LineResult<()> {
        self.skip_whitespace();
        if self.at_end() {
            Ok(())
        } else {
            Err((
                self.place(),
                ColorFileProblem::Expected {
                    expected: "end of line",
                    found: self.found(),
                },
            ))
        }
    }

    /// An optionally signed decimal integer in `min..=max`.
    fn integer_in(&mut self, what: &'static str, min: i64, max: i64) -> LineResult<i64> {
        self.skip_whitespace();
        let place = self.place();
        let start = self.pos;
        if matches!(self.peek(), Some('-' | '+')) {
            self.pos += 1;
        }
        let digits = self.take_while(|c| c.is_ascii_digit());
        let text = self.text.get(start..self.pos).unwrap_or("");
        if digits.is_empty() {
            self.pos = start;
            return Err((
                place,
                ColorFileProblem::Expected {
                    expected: "an integer",
                    found: self.found(),
                },
            ));
        }
        let out_of_range = || {
            (
                place,
                ColorFileProblem::OutOfRange {
                    what,
                    value: text.to_owned(),
                    min,
                    max,
                },
            )
        };
        let value = text.parse::<i64>().map_err(|_| out_of_range())?;
        if (min..=max).contains(&value) {
            Ok(value)
        } else {
            Err(out_of_range())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_ok(text: &str, expected_names: &[&str]) -> ColorConfig {
        let config = parse(text, "test.txt").unwrap_or_else(|e| panic!("{e}"));
        let names: Vec<&str> = config.colors.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, expected_names);
        config
    }

    fn check_err(text: &str, expected_message: &str) {
        match parse(text, "test.txt") {
            Ok(config) => panic!("parsed {config:?}, expected error {expected_message}"),
            Err(e) => assert_eq!(e.to_string(), expected_message),
        }
    }

    #[test]
    fn a_written_file_reads_back_the_same() {
        let mut config = check_ok(
            "[Colors]\n(255,128,  0) 0.000000 Ball\n( 1, 2,3) 0.5 10 Big Red\n(1,2,3) 0 1 None\n[Thresholds]\n( 12:153, 99:127,143:168)\n(0:1,2:3,4:5)\n(300:400,0:255,0:255)\n",
            &["Ball", "Big Red", "None"],
        );
        config.min_area_px = 30;
        let text = write(&config, "fitted by a test\nfrom here");
        assert_eq!(
            text,
            "# fitted by a test\n# from here\n\n[Colors]\n(255,128,  0) 0.000000 0 Ball\n(  1,  2,  3) 0.500000 10 Big Red\n(  1,  2,  3) 0.000000 1 None\n\n[Thresholds]\n( 12:153, 99:127,143:168)\n(  0:  1,  2:  3,  4:  5)\n(256:256,  0:255,  0:255)\n\n[Options]\nmin_area_px = 30\n"
        );
        assert_eq!(parse(&text, "written.txt").unwrap(), config);
    }

    #[test]
    fn colour_lines_with_and_without_expected_regions_parse() {
        let config = check_ok(
            "[Colors]\n(255,128,  0) 0.000000 Ball\n( 1, 2,3) 0.5 10 Big Red\n\n[Thresholds]\n( 12:153, 99:127,143:168)\n(0:1,2:3,4:5)\n",
            &["Ball", "Big Red"],
        );
        let ball = &config.colors[0];
        assert_eq!(ball.display_rgb, [255, 128, 0]);
        assert_eq!(ball.expected_regions, 0);
        assert_eq!(
            (ball.y, ball.u, ball.v),
            (
                ChannelRange { lo: 12, hi: 153 },
                ChannelRange { lo: 99, hi: 127 },
                ChannelRange { lo: 143, hi: 168 }
            )
        );
        assert_eq!(config.colors[1].expected_regions, 10);
        assert!((config.colors[1].merge_density - 0.5).abs() < 1e-12);
    }

    #[test]
    fn comments_crlf_and_missing_names_are_tolerated() {
        check_ok(
            "# a comment\r\n[ Colors ]  # trailing\r\n(1,2,3) 0 7\r\n[thresholds]\r\n ( 0 : 1 , 2 : 3 , 4 : 5 )  \r\n",
            &["color0"],
        );
    }

    #[test]
    fn thresholds_beyond_a_byte_are_clamped_and_ranges_outside_match_nothing() {
        let config = check_ok(
            "[Colors]\n(1,2,3) 0 A\n[Thresholds]\n(-5:300,256:400,0:255)\n",
            &["A"],
        );
        assert_eq!(config.colors[0].y, ChannelRange { lo: 0, hi: 255 });
        assert!(!(0..=255u8).any(|v| config.colors[0].u.contains(v)));
    }

    #[test]
    fn errors_name_the_line_and_column_and_the_problem() {
        check_err(
            "(1,2,3) 0 A\n",
            "test.txt:1:1: line outside a section: start the file with [Colors]",
        );
        check_err(
            "[Colors]\n(1,2 3) 0 A\n",
            "test.txt:2:6: expected , between colour components, found '3'",
        );
        check_err(
            "[Colors]\n(1,2,300) 0 A\n",
            "test.txt:2:6: blue 300 is out of range 0..=255",
        );
        check_err(
            "[Colors]\n(1,2,3) x A\n",
            "test.txt:2:9: merge density x must be a number of at least 0 (0 turns merging off)",
        );
        check_err(
            "[Colors]\n(1,2,3)\n",
            "test.txt:2:8: expected a merge density, found end of line",
        );
        check_err(
            "[Colours]\n(1,2,3) 0 A\n[Thresholds]\n(9:1,0:1,0:1)\n",
            "test.txt:4:2: Y range 9:1 is reversed: write the low value first",
        );
        check_err(
            "[Colors]\n(1,2,3) 0 A\n[Thresholds]\n(0:1,0:1,0:1) x\n",
            "test.txt:4:15: expected end of line, found 'x'",
        );
        check_err(
            "[Colors]\n(1,2,3) 0 A\n[Thresholds]\n",
            "test.txt:3:1: 1 colours but 0 thresholds: add one threshold line per colour",
        );
        check_err(
            "[Colors]\n(1,2,3) 0 A\n[Thresholds]\n(0:1,0:1,0:1)\n(0:1,0:1,0:1)\n",
            "test.txt:5:1: threshold 2 has no colour: [Colors] lists 1",
        );
        check_err(
            "[Shades]\n",
            "test.txt:1:2: unknown section [Shades]: use [Colors], [Thresholds] or [Options]",
        );
        check_err(
            "[Colors]\n[Colors]\n",
            "test.txt:2:1: section [Colors] appears twice: keep one",
        );
        check_err(
            "# nothing\n",
            "test.txt:1:1: no colours defined: add a [Colors] section (or [[color]] tables in TOML)",
        );
        check_err(
            "[Colors]\n(1,2,3) 0 99999999999 A\n",
            "test.txt:2:11: expected regions 99999999999 is out of range 0..=4294967295",
        );
    }

    #[test]
    fn the_options_section_sets_the_minimum_area() {
        let text = "[Colors]\n(1,2,3) 0 A\n[Thresholds]\n(0:1,0:1,0:1)\n";
        assert_eq!(check_ok(text, &["A"]).min_area_px, 1);
        let with = format!("[Options]\n min_area_px = 700 # candies\n{text}");
        assert_eq!(check_ok(&with, &["A"]).min_area_px, 700);
        check_err(
            &format!("{text}[Options]\nmin_area = 5\n"),
            "test.txt:6:1: unknown option `min_area`: the only option is min_area_px",
        );
        check_err(
            &format!("{text}[Options]\nmin_area_px 5\n"),
            "test.txt:6:13: expected = after the option's name, found '5'",
        );
        check_err(
            &format!("{text}[Options]\nmin_area_px = -5\n"),
            "test.txt:6:15: min_area_px -5 is out of range 0..=4294967295",
        );
        check_err(
            &format!("[Options]\n[Options]\n{text}"),
            "test.txt:2:1: section [Options] appears twice: keep one",
        );
    }

    #[test]
    fn a_33rd_colour_is_refused() {
        let mut text = String::from("[Colors]\n");
        for _ in 0..33 {
            text.push_str("(1,2,3) 0 A\n");
        }
        check_err(
            &text,
            "test.txt:34:1: more than 32 colours: CMVision classifies at most 32 at once",
        );
    }
}
