//! `lewis idl check` and `lewis idl show`.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::{Subcommand, ValueEnum};
use lewis_interfaces::idl;

/// `lewis idl ...`
#[derive(Debug, Subcommand)]
pub enum IdlCommand {
    /// Validate every XML definition of a folder; errors name file, line and column.
    Check {
        /// The folder of definitions (`NAME.xml` files beside a `types.xml`).
        #[arg(default_value = "interfaces/idl")]
        dir: PathBuf,
    },
    /// Show an interface (or a type) as ros2msg schema text, XML or generated Rust.
    Show {
        /// The interface or type name, e.g. `RangeFinder` or `Pose3D`.
        name: String,
        /// What to show.
        #[arg(long, value_enum, default_value_t = Format::Ros2msg)]
        format: Format,
        /// Read the definitions from this folder instead of those built into `lewis`.
        #[arg(long)]
        dir: Option<PathBuf>,
    },
}

/// How `lewis idl show` prints a definition.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// The ros2msg schema text stored in recordings, dependencies appended.
    Ros2msg,
    /// The XML definition.
    Xml,
    /// The Rust types generated from it.
    Rust,
}

pub fn run(command: IdlCommand) -> anyhow::Result<ExitCode> {
    let mut out = std::io::stdout().lock();
    match command {
        IdlCommand::Check { dir } => {
            if !dir.is_dir() {
                bail!(
                    "{} is not a folder of interface definitions; give the folder that holds the .xml files",
                    dir.display()
                );
            }
            match idl::load_dir(&dir) {
                Ok(idl) => {
                    writeln!(
                        out,
                        "{}: {} interfaces, {} types: ok",
                        dir.display(),
                        idl.interfaces.len(),
                        idl.types.len()
                    )?;
                    Ok(ExitCode::SUCCESS)
                }
                Err(diagnostics) => {
                    let count = diagnostics.0.len();
                    writeln!(out, "{diagnostics}")?;
                    writeln!(out, "{count} error{}", if count == 1 { "" } else { "s" })?;
                    Ok(ExitCode::FAILURE)
                }
            }
        }
        IdlCommand::Show { name, format, dir } => {
            let idl = match &dir {
                Some(dir) => idl::load_dir(dir).map_err(|d| anyhow::anyhow!("{d}"))?,
                None => lewis_interfaces::builtin_idl()
                    .map_err(|d| anyhow::anyhow!("{d}"))
                    .context("the built-in definitions do not validate")?,
            };
            let text = show(&idl, &name, format)?;
            write!(out, "{text}")?;
            Ok(ExitCode::SUCCESS)
        }
    }
}

fn show(idl: &idl::Idl, name: &str, format: Format) -> anyhow::Result<String> {
    if let Some(interface) = idl.interface(name) {
        return Ok(match format {
            Format::Ros2msg => {
                let mut text = idl::schema_text(idl, &interface.publication);
                for command in &interface.commands {
                    text.push_str(&format!(
                        "\n# command `{}`: {}/msg/{}\n{}",
                        command.name,
                        idl::PACKAGE,
                        command.request.name,
                        idl::schema_text(idl, &command.request)
                    ));
                    text.push_str(&format!(
                        "\n# reply: {}/msg/{}\n{}",
                        idl::PACKAGE,
                        command.reply.name,
                        idl::schema_text(idl, &command.reply)
                    ));
                }
                text
            }
            Format::Xml => interface.xml.clone(),
            Format::Rust => idl::generate_rust(idl, Some(name)),
        });
    }
    if let Some(ty) = idl.compound(name) {
        return match format {
            Format::Ros2msg => Ok(idl::schema_text(idl, ty)),
            Format::Xml | Format::Rust => bail!(
                "`{name}` is a type, not an interface: it is shown as ros2msg only; its XML is in types.xml"
            ),
        };
    }
    let mut names: Vec<&str> = idl.interfaces.iter().map(|i| i.name.as_str()).collect();
    names.extend(idl.types.iter().map(|t| t.name.as_str()));
    bail!(
        "no interface or type named `{name}`; known: {}",
        names.join(", ")
    )
}
