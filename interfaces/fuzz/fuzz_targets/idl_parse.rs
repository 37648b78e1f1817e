//! Any bytes as an interface definition beside the shipped types: a diagnostic or a
//! definition, never a panic.
#![no_main]

use std::path::PathBuf;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let mut sources: Vec<(PathBuf, String)> = lewis_interfaces::msg::TYPES_XML
        .iter()
        .map(|(file, xml)| (PathBuf::from(file), (*xml).to_owned()))
        .collect();
    sources.push((PathBuf::from("Fuzz.xml"), text.to_owned()));
    if let Ok(idl) = lewis_interfaces::idl::load_sources(&sources) {
        // Whatever validates must also generate.
        let _ = lewis_interfaces::idl::generate_rust(&idl, None);
        for s in idl.all_structs() {
            let _ = lewis_interfaces::idl::schema_text(&idl, s);
        }
    }
});
