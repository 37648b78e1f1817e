//! What the GUI tests drive a real browser with: Debian's Chromium, `node`, and the driver
//! scripts' `playwright-core` in `tools/node/`.

use std::path::PathBuf;
use std::process::Command;

use crate::repository_root;

/// The folder of the GUI driver scripts (`drive.mjs`, `recover.mjs`, `browser.mjs`).
#[must_use]
pub fn gui_test_dir() -> PathBuf {
    repository_root().join("tools/node")
}

/// The browser to drive (`LEWIS_CHROMIUM`, else `/usr/bin/chromium`), after checking that
/// it, `node` and `playwright-core` are there.
///
/// # Panics
/// When one is missing, with the command that installs it.
#[must_use]
pub fn browser_tools() -> PathBuf {
    let chromium = std::env::var_os("LEWIS_CHROMIUM")
        .map_or_else(|| PathBuf::from("/usr/bin/chromium"), PathBuf::from);
    assert!(
        chromium.is_file(),
        "the GUI test needs Chromium at {}: install it with `apt-get install -y chromium` \
         (or set LEWIS_CHROMIUM to its path)",
        chromium.display()
    );
    let node = Command::new("node").arg("--version").output();
    assert!(
        node.is_ok_and(|o| o.status.success()),
        "the GUI test needs `node` in PATH: install it with `apt-get install -y nodejs npm`"
    );
    assert!(
        gui_test_dir().join("node_modules/playwright-core").is_dir(),
        "the GUI test needs playwright-core: run `npm ci --prefix tools/node`"
    );
    chromium
}
