//! Splits one line of a script into words and quoted strings, dropping `#` comments.

use crate::diagnostic::Problem;

/// One word of a line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Token {
    /// The text, with a string's quotes removed and its escapes decoded.
    pub text: String,
    /// Whether it was written as a quoted string.
    pub quoted: bool,
    /// Its first column, from 1, in characters.
    pub column: u32,
    /// The column just after it.
    pub end_column: u32,
}

/// A problem found while splitting a line, at a column.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct LexError {
    pub column: u32,
    pub problem: Problem,
}

fn column(index: usize) -> u32 {
    u32::try_from(index + 1).unwrap_or(u32::MAX)
}

/// The words of `line`. A `#` at the start of a word begins a comment to the end of the
/// line; inside a word it is an ordinary character (`a#b` is one word).
pub(crate) fn tokenize(line: &str) -> Result<Vec<Token>, LexError> {
    let chars: Vec<char> = line.chars().collect();
    let mut tokens = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c.is_whitespace() {
            i += 1;
        } else if c == '#' {
            break;
        } else if c == '"' {
            let (token, next) = quoted(&chars, i)?;
            tokens.push(token);
            i = next;
        } else {
            let start = i;
            while i < chars.len() && !chars[i].is_whitespace() {
                if chars[i] == '"' {
                    return Err(LexError {
                        column: column(i),
                        problem: Problem::QuoteInsideWord {
                            word: chars[start..i].iter().collect(),
                        },
                    });
                }
                i += 1;
            }
            tokens.push(Token {
                text: chars[start..i].iter().collect(),
                quoted: false,
                column: column(start),
                end_column: column(i),
            });
        }
    }
    Ok(tokens)
}

/// The string that opens at `chars[open]`, and the index after it.
fn quoted(chars: &[char], open: usize) -> Result<(Token, usize), LexError> {
    let mut text = String::new();
    let mut i = open + 1;
    loop {
        match chars.get(i) {
            None => {
                return Err(LexError {
                    column: column(open),
                    problem: Problem::UnterminatedString,
                });
            }
            Some('"') => break,
            Some('\\') => {
                let (decoded, next) = escape(chars, i)?;
                text.push(decoded);
                i = next;
            }
            Some(&c) => {
                text.push(c);
                i += 1;
            }
        }
    }
    let after = i + 1;
    if chars.get(after).is_some_and(|c| !c.is_whitespace()) {
        return Err(LexError {
            column: column(after),
            problem: Problem::NoSpaceAfterString,
        });
    }
    let token = Token {
        text,
        quoted: true,
        column: column(open),
        end_column: column(after),
    };
    Ok((token, after))
}

/// The character of the escape at `chars[backslash]`, and the index after it.
fn escape(chars: &[char], backslash: usize) -> Result<(char, usize), LexError> {
    let unknown = |end: usize| LexError {
        column: column(backslash),
        problem: Problem::UnknownEscape {
            escape: chars[backslash..end.min(chars.len())].iter().collect(),
        },
    };
    let simple = match chars.get(backslash + 1) {
        None => {
            return Err(LexError {
                column: column(backslash),
                problem: Problem::UnterminatedString,
            });
        }
        Some('\\') => '\\',
        Some('"') => '"',
        Some('n') => '\n',
        Some('t') => '\t',
        Some('r') => '\r',
        Some('0') => '\0',
        Some('u') => {
            return unicode(chars, backslash).ok_or_else(|| unknown(unicode_end(chars, backslash)));
        }
        Some(_) => return Err(unknown(backslash + 2)),
    };
    Ok((simple, backslash + 2))
}

/// Where a `\u{...}` escape written at `backslash` ends, for the error message.
fn unicode_end(chars: &[char], backslash: usize) -> usize {
    chars[backslash..]
        .iter()
        .position(|&c| c == '}' || c == '"' || c.is_whitespace())
        .map_or(chars.len(), |offset| {
            let end = backslash + offset;
            if chars[end] == '}' { end + 1 } else { end }
        })
        .max(backslash + 2)
}

/// Decodes `\u{HEX}` (1 to 6 hex digits naming a Unicode scalar value).
fn unicode(chars: &[char], backslash: usize) -> Option<(char, usize)> {
    if chars.get(backslash + 2) != Some(&'{') {
        return None;
    }
    let digits_start = backslash + 3;
    let close = digits_start + chars.get(digits_start..)?.iter().position(|&c| c == '}')?;
    let digits: String = chars[digits_start..close].iter().collect();
    if digits.is_empty() || digits.len() > 6 {
        return None;
    }
    let value = u32::from_str_radix(&digits, 16).ok()?;
    Some((char::from_u32(value)?, close + 1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use expect_test::{Expect, expect};

    fn check(line: &str, expected: &Expect) {
        let actual = match tokenize(line) {
            Ok(tokens) => tokens
                .iter()
                .map(|t| {
                    let kind = if t.quoted { "string" } else { "word" };
                    format!("{kind} {:?} {}..{}", t.text, t.column, t.end_column)
                })
                .collect::<Vec<_>>()
                .join("\n"),
            Err(e) => format!("error at {}: {}", e.column, e.problem),
        };
        expected.assert_eq(&actual);
    }

    #[test]
    fn words_are_split_on_whitespace_with_columns() {
        check(
            "  state door\t./bin/door",
            &expect![[r#"
                word "state" 3..8
                word "door" 9..13
                word "./bin/door" 14..24"#]],
        );
    }

    #[test]
    fn a_comment_ends_the_line_but_a_hash_inside_a_word_does_not() {
        check(
            "action 0 trans stop # done\n",
            &expect![[r#"
                word "action" 1..7
                word "0" 8..9
                word "trans" 10..15
                word "stop" 16..20"#]],
        );
        check(
            "env A=b#c",
            &expect![[r#"
            word "env" 1..4
            word "A=b#c" 5..10"#]],
        );
        check("# only a comment", &expect![""]);
    }

    #[test]
    fn strings_decode_their_escapes() {
        check(
            r#"state s "./my prog" "say \"hi\"\n" "\u{e9}t\u{E9}" """#,
            &expect![[r#"
                word "state" 1..6
                word "s" 7..8
                string "./my prog" 9..20
                string "say \"hi\"\n" 21..35
                string "été" 36..51
                string "" 52..54"#]],
        );
    }

    #[test]
    fn a_hash_inside_a_string_is_not_a_comment() {
        check(
            r##"state s p "#1""##,
            &expect![[r##"
            word "state" 1..6
            word "s" 7..8
            word "p" 9..10
            string "#1" 11..15"##]],
        );
    }

    #[test]
    fn columns_count_characters_not_bytes() {
        check(
            "état \"é\" x",
            &expect![[r#"
            word "état" 1..5
            string "é" 6..9
            word "x" 10..11"#]],
        );
    }

    #[test]
    fn broken_strings_are_errors_at_the_right_column() {
        check(
            r#"state s p "open"#,
            &expect!["error at 11: unterminated string"],
        );
        check(
            r#"state s p "a\qb""#,
            &expect![r#"error at 13: unknown escape `\q` in a string"#],
        );
        check(
            r#"state s p "a\u{110000}""#,
            &expect![r#"error at 13: unknown escape `\u{110000}` in a string"#],
        );
        check(
            r#"state s p "a\u{zz" b"#,
            &expect![r#"error at 13: unknown escape `\u{zz` in a string"#],
        );
        check(
            r#"state s p "a\"#,
            &expect!["error at 13: unterminated string"],
        );
        check(
            r#"state s p"x""#,
            &expect![r#"error at 10: unexpected `"` inside the word `p`"#],
        );
        check(
            r#"state s "p"x"#,
            &expect!["error at 12: expected a space after the closing quote"],
        );
    }
}
