//! A test that cannot set up what it needs (a tool, root, a device, namespaces): skipped
//! with its reason on a developer's machine, failed with it under CI, which must set up
//! what its tests need. One rule, so no test prints "skipped" and passes in CI.

/// Whether the tests run under CI (the `CI` variable set, as CI services and `.ci/run`
/// set it).
#[must_use]
pub fn under_ci() -> bool {
    std::env::var_os("CI").is_some()
}

/// Ends the test because it cannot set up what it needs: under CI the test fails with the
/// reason; elsewhere it prints `skipped: REASON` and returns. Takes `format!` arguments.
#[macro_export]
macro_rules! skip_unless_ci {
    ($($reason:tt)+) => {{
        let reason = ::std::format!($($reason)+);
        if $crate::skip::under_ci() {
            ::std::panic!("CI cannot set up this test: {reason}");
        }
        ::std::eprintln!("skipped: {reason}");
        return;
    }};
}
