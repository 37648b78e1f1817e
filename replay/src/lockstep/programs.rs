//! The sub-task programs of `lewis-apps` as the programs of a mission lived again
//! (`lewis replay --all`, the demo, the sweep, the closed-loop bench): [`AppPrograms`].
//!
//! A mission state's program is a file; one of Lewis's own programs is a wrapper that runs
//! `lewis app NAME` (those of `robots/missions/bin/`). Its NAME is read from the file, and
//! its arguments as `lewis app NAME` reads them: the command line's grammar is the `lewis`
//! command's, so it is handed in ([`ReadAppArgs`]) rather than written again here.

use std::path::Path;

use lewis_apps::App;

use super::mission::{Program, Programs};

/// How the `lewis` command reads `lewis app NAME ARGS...`: the program `name` with `args`,
/// or why they are wrong (its message names `wrapper`, the file they were read for).
pub type ReadAppArgs = fn(wrapper: &Path, name: &str, args: &[String]) -> Result<App, String>;

/// The programs of a mission lived again: a state's program is one of these when its file
/// runs `lewis app NAME` (the wrappers of `robots/missions/bin/`); its arguments are read as
/// `lewis app NAME` reads them.
#[derive(Debug, Clone, Copy)]
pub struct AppPrograms {
    read_args: ReadAppArgs,
}

impl AppPrograms {
    /// The programs of `lewis-apps`, their arguments read with `read_args`.
    #[must_use]
    pub const fn new(read_args: ReadAppArgs) -> Self {
        Self { read_args }
    }
}

impl Programs for AppPrograms {
    fn build(&self, program: &Path, args: &[String]) -> Result<Program, String> {
        let text = std::fs::read_to_string(program)
            .map_err(|e| format!("cannot read {}: {e}", program.display()))?;
        let name = app_named_in(&text).ok_or_else(|| {
            format!(
                "{} does not run `lewis app`: only lewis's own programs can be lived again",
                program.display()
            )
        })?;
        let app = (self.read_args)(program, &name, args)?;
        Ok(Program {
            name: app.name().to_owned(),
            requires: app.requires().iter().map(|s| (*s).to_owned()).collect(),
            service: app.program(),
        })
    }
}

/// The NAME of the first `... app NAME` in a wrapper script's lines (comments skipped).
fn app_named_in(text: &str) -> Option<String> {
    text.lines()
        .map(str::trim)
        .filter(|line| !line.starts_with('#'))
        .find_map(|line| {
            let mut words = line.split_whitespace().map(|w| w.trim_matches(['"', '\'']));
            words.find(|w| *w == "app")?;
            words.next().map(str::to_owned)
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wrapper_names_its_program() {
        let wrapper = "#!/bin/sh\n# runs `lewis app sign-follower`\nexec \"${LEWIS_EXE:-lewis}\" app sign-follower \"$@\"\n";
        assert_eq!(app_named_in(wrapper).as_deref(), Some("sign-follower"));
        assert_eq!(app_named_in("#!/bin/sh\nexec other-tool \"$@\"\n"), None);
    }
}
