//! `my-lewis`: the `lewis` command with `front-clearance` added to Lewis's own kinds. Every
//! command of `lewis` works, and `up`, `service`, `replay` and `demo` know the new kind.

use std::process::ExitCode;

fn main() -> ExitCode {
    let mut registry = lewis_kinds::registry();
    lewis_example_front_clearance::register(&mut registry);
    lewis::main_with(registry)
}
