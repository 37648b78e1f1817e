#!/usr/bin/env bash
# The user guide: build the mdBook in docs/ into docs/book/ with its link checker as a
# second backend, so a link to a chapter or an image that does not exist fails the
# build. Installs mdbook and mdbook-linkcheck2 from crates.io (cargo install --locked, into
# cargo's bin folder) when they are missing. The guide's commands and references are
# checked by tests: `cargo test -p lewis-tests --test it docs::` and
# `cargo test -p lewis --test commands reference`.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
MDBOOK_VERSION=0.5.4
LINKCHECK_VERSION=0.13.0
bin="${CARGO_HOME:-$HOME/.cargo}/bin"
export PATH="$bin:$PATH"
installed() { # NAME VERSION: whether NAME --version prints VERSION
    command -v "$1" > /dev/null && "$1" --version 2>/dev/null | grep -qF "$2"
}
if ! installed mdbook "$MDBOOK_VERSION"; then
    # Not CARGO_TARGET_DIR: a tool's build has no business in the workspace's target folder.
    env -u CARGO_TARGET_DIR cargo install --locked --quiet mdbook --version "$MDBOOK_VERSION"
fi
if ! installed mdbook-linkcheck2 "$LINKCHECK_VERSION"; then
    env -u CARGO_TARGET_DIR cargo install --locked --quiet mdbook-linkcheck2 --version "$LINKCHECK_VERSION"
fi
mdbook build docs
echo "docs: built docs/book/html/index.html, links checked"
