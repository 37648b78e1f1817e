//! Generates the Rust types of `idl/*.xml` into `$OUT_DIR/generated.rs`.

#[allow(dead_code, unused_imports, missing_docs, clippy::all)]
#[path = "src/idl/mod.rs"]
mod idl;

use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let dir = manifest.join("idl");
    println!("cargo::rerun-if-changed={}", dir.display());
    println!("cargo::rerun-if-changed=src/idl");
    let idl = match idl::load_dir(&dir) {
        Ok(idl) => idl,
        Err(diagnostics) => {
            // Cargo shows a build script's stderr when it fails: the diagnostics with
            // file:line:column are what the developer needs.
            #[allow(clippy::print_stderr)]
            {
                eprintln!("{diagnostics}");
            }
            return ExitCode::FAILURE;
        }
    };
    let out = PathBuf::from(std::env::var_os("OUT_DIR").unwrap_or_default()).join("generated.rs");
    let source = idl::generate_rust(&idl, None);
    if let Err(err) = std::fs::write(&out, source) {
        #[allow(clippy::print_stderr)]
        {
            eprintln!("cannot write {}: {err}", out.display());
        }
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}
