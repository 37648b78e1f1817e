//! The `lewis` command. Thin: it parses the command line, calls one `run`, and maps the
//! result to an exit code.

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let cli = lewis::Cli::parse();
    match lewis::run(cli) {
        Ok(code) => code,
        Err(err) => {
            #[allow(clippy::print_stderr)]
            {
                eprintln!("error: {}", lewis::error_text(&err));
            }
            ExitCode::from(2)
        }
    }
}
