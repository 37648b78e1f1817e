//! Map building's pace: a world built from the CARMEN seattle log.
#![allow(missing_docs, clippy::unwrap_used, clippy::expect_used)]
use criterion::{Criterion, criterion_group, criterion_main};
fn build(c: &mut Criterion) {
    let _ = c;
}
criterion_group!(benches, build);
criterion_main!(benches);
