//! The `lewis` command. Thin: everything is [`lewis::main_with`], given Lewis's own service
//! kinds.

use std::process::ExitCode;

fn main() -> ExitCode {
    lewis::main_with(lewis_kinds::registry())
}
