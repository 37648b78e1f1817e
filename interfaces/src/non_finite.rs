//! The place of a number in a message, written as the generated `first_non_finite` finds
//! it: field names joined by dots, array elements by their index (`points[1].x`).

use std::fmt::Write as _;

/// Appends field `name` to `path`.
pub(crate) fn push_field(path: &mut String, name: &str) {
    if !path.is_empty() {
        path.push('.');
    }
    path.push_str(name);
}

/// Appends element `index` of array field `name` to `path`.
pub(crate) fn push_index(path: &mut String, name: &str, index: usize) {
    push_field(path, name);
    let _ = write!(path, "[{index}]");
}
