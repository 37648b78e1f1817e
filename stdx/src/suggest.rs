//! "Did you mean" suggestions: the closest candidate by edit distance, when it is close.

/// The edit distance between `a` and `b` counting insertions, deletions, substitutions and
/// swaps of neighbours (optimal string alignment), over lower-cased characters.
fn distance(a: &str, b: &str) -> usize {
    strsim::osa_distance(&a.to_lowercase(), &b.to_lowercase())
}

/// Whether `found` is plausibly a misspelling of `wanted`.
#[must_use]
pub fn is_close(found: &str, wanted: &str) -> bool {
    // Long words are compared only when their lengths are near, which also bounds the work.
    let (found_len, wanted_len) = (found.chars().count(), wanted.chars().count());
    if found_len.abs_diff(wanted_len) > 2 || found_len > 64 {
        return false;
    }
    let limit = if wanted_len <= 4 { 1 } else { 2 };
    distance(found, wanted) <= limit
}

/// The candidate closest to `found`, when one is close enough to suggest.
#[must_use]
pub fn closest<'a>(found: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    candidates
        .into_iter()
        .filter(|candidate| is_close(found, candidate))
        // On a tie, a candidate that the word begins (`stat` for `state`) is the likelier.
        .min_by_key(|candidate| (distance(found, candidate), !candidate.starts_with(found)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(found: &str, candidates: &[&'static str], expected: Option<&str>) {
        assert_eq!(
            closest(found, candidates.iter().copied()),
            expected,
            "for `{found}`"
        );
    }

    #[test]
    fn swapped_letters_suggest_the_keyword() {
        check("trnas", &["trans", "start"], Some("trans"));
        check("satte", &["state", "start"], Some("state"));
    }

    #[test]
    fn capitals_still_suggest_the_keyword() {
        check("State", &["state", "start"], Some("state"));
    }

    #[test]
    fn distant_words_suggest_nothing() {
        check("banana", &["state", "start", "recovery"], None);
        check("", &["use"], None);
    }

    #[test]
    fn the_closest_of_several_wins() {
        check("strat", &["start", "state"], Some("start"));
        check("stat", &["start", "state"], Some("state"));
    }
}
