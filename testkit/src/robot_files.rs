//! Texts of the shipped robot files as the end-to-end tests and benchmarks run them: paths
//! made absolute (the tests run `lewis up` in a temporary directory), and the simulated
//! robot on two hosts.

// Helpers of tests: a missing file of the repository is the test's failure.
#![allow(clippy::expect_used)]

/// The text of the shipped robot file `robots/NAME` with every `= "robots/..."` path (the
/// world, colour files) made absolute: the tests run `lewis up` in a temporary directory.
///
/// # Panics
/// When the file is not in the repository.
#[must_use]
pub fn shipped_robot(name: &str) -> String {
    let text = std::fs::read_to_string(crate::repository_root().join("robots").join(name))
        .unwrap_or_else(|e| panic!("robots/{name} is in the repository: {e}"));
    with_absolute_paths(&text)
}

/// A robot file's text with every `= "robots/..."` path made absolute.
#[must_use]
pub fn with_absolute_paths(text: &str) -> String {
    text.replace(
        "= \"robots/",
        &format!("= \"{}/robots/", crate::repository_root().display()),
    )
}

/// `robots/sim.toml` on two hosts, as the multi-host tests and benchmarks run it: the robot
/// host `robot` (10.0.0.1) with the simulated devices, the workstation `workstation`
/// (10.0.0.2) with the perception (blobfinder, sign_detector), and an on-board blobfinder
/// (quality 5) that stands in when the workstation is gone; `extra` appended. Its paths
/// are relative to the repository's root, where `lewis up` must run.
///
/// # Panics
/// When `robots/sim.toml` is not in the repository or has no service.
#[must_use]
pub fn sim_on_two_hosts(extra: &str) -> String {
    let sim = std::fs::read_to_string(crate::repository_root().join("robots/sim.toml"))
        .expect("robots/sim.toml is in the repository");
    let first_service = sim.find("[[services]]").expect("the robot has services");
    let hosts = "[[hosts]]\nname = \"robot\"\nlisten = [\"tcp/10.0.0.1:7447\"]\n\n\
                 [[hosts]]\nname = \"workstation\"\nlisten = [\"tcp/10.0.0.2:7447\"]\n\n";
    let mut text = format!("{}{hosts}{}", &sim[..first_service], &sim[first_service..]);
    for service in ["blobfinder", "sign_detector"] {
        text = text.replacen(
            &format!("name = \"{service}\"\n"),
            &format!("name = \"{service}\"\nhost = \"workstation\"\n"),
            1,
        );
    }
    text.push_str(
        r#"
[[services]]
name = "blobfinder_onboard"
kind = "blobfinder"
start = "on-demand"
requires = ["ImageSource"]
provides = [{ interface = "Blobs", quality = 5, cost = 3, data_rate_hz = 5.0 }]

[services.parameters]
colors = "robots/colors/conference.txt"
min_area_px = 20
max_blobs_per_color = 16
"#,
    );
    text.push_str(extra);
    text
}
