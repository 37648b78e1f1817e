//! `lewis app door-navigator|sign-follower|queue-stander|register|recovery [ARGS]`: one of
//! the Robot Challenge's sub-task programs (`lewis-apps`), in this process, until it
//! finishes; the process exits with the program's code (the mission script routes it).
//!
//! The sequencer runs them through `robots/missions/bin/*`, wrappers that call this.

use std::collections::BTreeSet;
use std::path::Path;
use std::process::ExitCode;

use clap::{Args, Subcommand};
use lewis_apps::App;
use lewis_apps::door::DoorConfig;
use lewis_apps::queue::QueueConfig;
use lewis_apps::recovery::RecoveryConfig;
use lewis_apps::register::RegisterConfig;
use lewis_apps::sign::{ArrowWord, SignConfig};
use lewis_replay::lockstep::AppPrograms;
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

/// The programs of a mission lived again (`lewis replay --all`, the demo, the sweep, the
/// bench): `lewis-apps`'s, their arguments read as `lewis app NAME` reads them.
pub fn programs() -> AppPrograms {
    AppPrograms::new(read_args)
}

/// The program `lewis app NAME ARGS...` runs, for the wrapper `wrapper` (named in the
/// message of a bad argument).
fn read_args(wrapper: &Path, name: &str, args: &[String]) -> Result<App, String> {
    use clap::Parser as _;

    #[derive(Debug, clap::Parser)]
    struct Line {
        #[command(flatten)]
        args: AppArgs,
    }

    let argv = ["lewis-app", name]
        .into_iter()
        .map(str::to_owned)
        .chain(args.iter().cloned());
    let line = Line::try_parse_from(argv).map_err(|e| {
        let text = e.to_string();
        format!(
            "{}: {}",
            wrapper.display(),
            text.lines().next().unwrap_or_default()
        )
    })?;
    line.args.app().map_err(|e| e.to_string())
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
