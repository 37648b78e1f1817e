//! Positions in text for error messages.

/// The 1-based line and column (in characters) of byte `offset` in `text`; an offset past
/// the end or inside a character is moved back to the nearest character boundary.
#[must_use]
pub fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    (line, column)
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    #[test]
    fn lines_and_columns_count_from_one_in_characters() {
        let text = "ab\ncé d\n";
        assert_eq!(line_column(text, 0), (1, 1));
        assert_eq!(line_column(text, 3), (2, 1));
        // `d` is after a two-byte character: column 4, not 5.
        assert_eq!(line_column(text, 7), (2, 4));
        assert_eq!(line_column(text, 1000), (3, 1));
    }

    #[test]
    fn positions_count_characters_and_survive_offsets_past_the_end() {
        assert_eq!(line_column("ab\ncd", 0), (1, 1));
        assert_eq!(line_column("ab\ncd", 4), (2, 2));
        assert_eq!(line_column("é\nx", 1), (1, 1));
        assert_eq!(line_column("é\nx", 2), (1, 2));
        assert_eq!(line_column("ab", 99), (1, 3));
    }

    #[test]
    fn an_offset_inside_a_character_moves_back_to_its_start() {
        assert_eq!(line_column("cé", 2), (1, 2));
    }

    proptest! {
        #[test]
        fn any_offset_of_any_text_has_a_position(text in "\\PC{0,40}", offset in 0usize..60) {
            let (line, column) = line_column(&text, offset);
            prop_assert!(line >= 1 && column >= 1);
        }
    }
}
