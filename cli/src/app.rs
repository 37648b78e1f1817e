//! `lewis app door-navigator|sign-follower|queue-stander|register|recovery [ARGS]`: one of
//! the Robot Challenge's sub-task programs (`lewis-apps`), in this process, until it
//! finishes; the process exits with the program's code (the mission script routes it).
//!
//! The sequencer runs them through `robots/missions/bin/*`, wrappers that call this.

use std::collections::BTreeSet;
use std::process::ExitCode;

use clap::{Args, Subcommand};
use lewis_apps::App;
use lewis_apps::door::DoorConfig;
use lewis_apps::queue::QueueConfig;
use lewis_apps::recovery::RecoveryConfig;
use lewis_apps::register::RegisterConfig;
use lewis_apps::sign::{ArrowWord, SignConfig};
use lewis_runtime::ipc::Namespace;
use lewis_runtime::live::ClockSource;

/// Arguments of `lewis app`.
#[derive(Debug, Args)]
pub struct AppArgs {
    /// The program.
    #[command(subcommand)]
    pub program: AppCommand,
    /// The IPC namespace of the running robot (default: `LEWIS_NAMESPACE`, else `default`).
    #[arg(long, global = true)]
    pub namespace: Option<String>,
    /// The clock: `wall` or `played` (default: `LEWIS_CLOCK`, else `wall`).
    #[arg(long, value_name = "CLOCK", global = true)]
    pub clock: Option<ClockSource>,
    /// How long a required input may be silent before the program stops the robot and
    /// exits with 3.
    #[arg(long, default_value = "5s", value_parser = duration_ns, global = true)]
    pub stale: i64,
}

/// The programs.
#[derive(Debug, Subcommand)]
pub enum AppCommand {
    /// Through the open door ahead (exit 0; 4: none found).
    DoorNavigator {
        /// The narrowest gap taken for a door, in m.
        #[arg(long, default_value_t = 0.9)]
        door_width: f64,
        /// When it gives up.
        #[arg(long, default_value = "60s", value_parser = duration_ns)]
        timeout: i64,
    },
    /// To the nearest direction sign, the way it says, until the next (exit 0) or the
    /// registration desk's sign (exit 1; 4: no sign for --timeout).
    SignFollower {
        /// An arrow to follow (`arrow left`, `right`); repeat it; none: every arrow.
        #[arg(long = "signs", value_name = "ARROW")]
        signs: Vec<String>,
        /// How long it goes without a new sign before giving up.
        #[arg(long, default_value = "60s", value_parser = duration_ns)]
        timeout: i64,
    },
    /// Into the desk's queue, up to its head (exit 0; 4: not there in --timeout).
    QueueStander {
        /// When it gives up.
        #[arg(long, default_value = "3m", value_parser = duration_ns)]
        timeout: i64,
    },
    /// Asks the registrar to register the robot (exit 0: yes; 4: no, or no answer).
    Register {
        /// The name on the robot's badge, said in its words.
        #[arg(long, default_value = "Lewis")]
        badge_text: String,
        /// How long it waits for an answer before asking once more.
        #[arg(long, default_value = "20s", value_parser = duration_ns)]
        wait: i64,
    },
    /// Follows the guide in the red cap back to a safe place (exit 0; 4: nobody found).
    Recovery {
        /// Whom to follow: the first word is the colour of their cap (`red cap`).
        #[arg(long, default_value = "red cap")]
        follow: String,
        /// The colour class to follow, as the blob finder names it (instead of --follow).
        #[arg(long)]
        colour: Option<String>,
    },
}

fn duration_ns(text: &str) -> Result<i64, String> {
    lewis_stdx::parse_duration_ns(text).map_err(|e| format!("{e}: {}", e.hint()))
}

impl AppArgs {
    /// The program with its settings.
    ///
    /// # Errors
    /// An arrow that is no arrow.
    pub fn app(&self) -> anyhow::Result<App> {
        let stale_ns = self.stale;
        Ok(match &self.program {
            AppCommand::DoorNavigator {
                door_width,
                timeout,
            } => App::DoorNavigator(DoorConfig {
                min_width_m: *door_width,
                stale_ns,
                timeout_ns: *timeout,
            }),
            AppCommand::SignFollower { signs, timeout } => {
                let arrows = signs
                    .iter()
                    .map(|s| ArrowWord::parse(s))
                    .collect::<Result<BTreeSet<_>, _>>()
                    .map_err(|e| anyhow::anyhow!("--signs {e}"))?;
                App::SignFollower(SignConfig {
                    arrows,
                    stale_ns,
                    timeout_ns: *timeout,
                })
            }
            AppCommand::QueueStander { timeout } => App::QueueStander(QueueConfig {
                stale_ns,
                timeout_ns: *timeout,
            }),
            AppCommand::Register { badge_text, wait } => App::Register(RegisterConfig {
                words: format!("Hello, I am {badge_text}. I would like to register."),
                wait_ns: *wait,
                ..RegisterConfig::default()
            }),
            AppCommand::Recovery { follow, colour } => App::Recovery(RecoveryConfig {
                colour: colour
                    .clone()
                    .unwrap_or_else(|| RecoveryConfig::colour_of(follow)),
                stale_ns,
                ..RecoveryConfig::default()
            }),
        })
    }
}

/// The programs of a mission lived again by `lewis replay --all`: a state's program is one
/// of these when its file runs `lewis app NAME` (the wrappers of `robots/missions/bin/`);
/// its arguments are read as `lewis app NAME` reads them.
#[derive(Debug, Clone, Copy, Default)]
pub struct AppPrograms;

impl lewis_replay::lockstep::Programs for AppPrograms {
    fn build(
        &self,
        program: &std::path::Path,
        args: &[String],
    ) -> Result<lewis_replay::lockstep::Program, String> {
        use clap::Parser as _;

        #[derive(Debug, clap::Parser)]
        struct Line {
            #[command(flatten)]
            args: AppArgs,
        }

        let text = std::fs::read_to_string(program)
            .map_err(|e| format!("cannot read {}: {e}", program.display()))?;
        let name = app_named_in(&text).ok_or_else(|| {
            format!(
                "{} does not run `lewis app`: only lewis's own programs can be lived again",
                program.display()
            )
        })?;
        let argv = ["lewis-app", name.as_str()]
            .into_iter()
            .map(str::to_owned)
            .chain(args.iter().cloned());
        let line = Line::try_parse_from(argv).map_err(|e| {
            let text = e.to_string();
            format!(
                "{}: {}",
                program.display(),
                text.lines().next().unwrap_or_default()
            )
        })?;
        let app = line.args.app().map_err(|e| e.to_string())?;
        Ok(lewis_replay::lockstep::Program {
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

/// Runs `lewis app`: the program's exit code.
pub fn run(args: &AppArgs) -> anyhow::Result<ExitCode> {
    let app = args.app()?;
    let namespace = Namespace::from_arg(args.namespace.as_deref())?;
    let clock = crate::service::clock_source(args.clock)?;
    let code = lewis_launch::program::run_app(app, &namespace, clock)?;
    Ok(ExitCode::from(u8::try_from(code).unwrap_or(1)))
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        args: AppArgs,
    }

    #[test]
    fn a_wrapper_names_its_program() {
        let wrapper = "#!/bin/sh\n# runs `lewis app sign-follower`\nexec \"${LEWIS_EXE:-lewis}\" app sign-follower \"$@\"\n";
        assert_eq!(app_named_in(wrapper).as_deref(), Some("sign-follower"));
        assert_eq!(app_named_in("#!/bin/sh\nexec other-tool \"$@\"\n"), None);
    }

    fn app(line: &[&str]) -> App {
        let mut argv = vec!["lewis-app"];
        argv.extend_from_slice(line);
        Cli::try_parse_from(argv).unwrap().args.app().unwrap()
    }

    #[test]
    fn the_arguments_of_the_mission_scripts_parse() {
        assert!(matches!(
            app(&["door-navigator", "--door-width", "0.9"]),
            App::DoorNavigator(DoorConfig { min_width_m, .. }) if (min_width_m - 0.9).abs() < 1e-12
        ));
        let App::SignFollower(sign) = app(&[
            "sign-follower",
            "--signs",
            "arrow left",
            "--signs",
            "arrow right",
        ]) else {
            panic!("not a sign follower");
        };
        assert_eq!(
            sign.arrows,
            BTreeSet::from([ArrowWord::Left, ArrowWord::Right])
        );
        let App::Register(register) = app(&["register", "--badge-text=Lewis\u{2122}"]) else {
            panic!("not register");
        };
        assert!(
            register.words.contains("Lewis\u{2122}"),
            "{}",
            register.words
        );
        let App::Recovery(recovery) = app(&["recovery", "--follow", "red cap"]) else {
            panic!("not recovery");
        };
        assert_eq!(recovery.colour, "Red");
        assert!(matches!(app(&["queue-stander"]), App::QueueStander(_)));
        let App::DoorNavigator(door) = app(&["door-navigator", "--stale", "500ms"]) else {
            panic!("not a door navigator");
        };
        assert_eq!(door.stale_ns, 500_000_000);
    }
}
