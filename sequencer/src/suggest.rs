//! "Did you mean" suggestions: the closest candidate by edit distance, when it is close.

/// The edit distance between `a` and `b` counting insertions, deletions, substitutions and
/// swaps of neighbours (optimal string alignment), over lower-cased characters.
fn distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().flat_map(char::to_lowercase).collect();
    let b: Vec<char> = b.chars().flat_map(char::to_lowercase).collect();
    // Three rows suffice for the swap rule.
    let mut before: Vec<usize> = vec![0; b.len() + 1];
    let mut previous: Vec<usize> = (0..=b.len()).collect();
    let mut current: Vec<usize> = vec![0; b.len() + 1];
    for i in 1..=a.len() {
        current[0] = i;
        for j in 1..=b.len() {
            let substitution = usize::from(a[i - 1] != b[j - 1]);
            let mut best = (previous[j] + 1)
                .min(current[j - 1] + 1)
                .min(previous[j - 1] + substitution);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                best = best.min(before[j - 2] + 1);
            }
            current[j] = best;
        }
        std::mem::swap(&mut before, &mut previous);
        std::mem::swap(&mut previous, &mut current);
    }
    previous[b.len()]
}

/// Whether `found` is plausibly a misspelling of `wanted`.
pub(crate) fn is_close(found: &str, wanted: &str) -> bool {
    // Long words are compared only when their lengths are near, which also bounds the work.
    let (found_len, wanted_len) = (found.chars().count(), wanted.chars().count());
    if found_len.abs_diff(wanted_len) > 2 || found_len > 64 {
        return false;
    }
    let limit = if wanted_len <= 4 { 1 } else { 2 };
    distance(found, wanted) <= limit
}

/// The candidate closest to `found`, when one is close enough to suggest.
pub(crate) fn closest<'a>(
    found: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<&'a str> {
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
