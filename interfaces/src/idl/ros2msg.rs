//! ros2msg schema text, as ROS 2 writes it into MCAP files: the message's own `.msg`
//! text, then each type it uses (transitively, in order of first use) after a line of 80
//! `=` and a `MSG: package/Type` line. The words a String field may hold are string
//! constants above it.

use std::collections::BTreeSet;

use super::model::{FieldType, HEADER_TYPE, Idl, PACKAGE, StructType};

/// The ros2msg schema text of `ty` (with its dependencies), or `None` when it uses a
/// type that `idl` does not define.
#[must_use]
pub fn schema_text(idl: &Idl, ty: &StructType) -> String {
    let mut text = msg_text(ty);
    let mut seen = BTreeSet::new();
    seen.insert(ty.name.clone());
    let mut order = Vec::new();
    dependencies(idl, ty, &mut seen, &mut order);
    for dep in order {
        if let Some(dep_ty) = idl.compound(&dep) {
            text.push_str(&"=".repeat(80));
            text.push('\n');
            text.push_str(&format!("MSG: {PACKAGE}/{dep}\n"));
            text.push_str(&msg_text(dep_ty));
        }
    }
    text
}

/// Depth-first, in field order: the order ROS 2 uses.
fn dependencies(idl: &Idl, ty: &StructType, seen: &mut BTreeSet<String>, order: &mut Vec<String>) {
    let header = ty.has_header().then(|| HEADER_TYPE.to_owned());
    let names = header
        .into_iter()
        .chain(ty.fields.iter().filter_map(|f| match &f.ty {
            FieldType::Struct(name) => Some(name.clone()),
            FieldType::Primitive { .. } => None,
        }));
    for name in names {
        if seen.insert(name.clone()) {
            order.push(name.clone());
            if let Some(dep) = idl.compound(&name) {
                dependencies(idl, dep, seen, order);
            }
        }
    }
}

fn msg_text(ty: &StructType) -> String {
    let mut text = String::new();
    if ty.has_header() {
        text.push_str(&format!("{PACKAGE}/{HEADER_TYPE} header\n"));
    }
    for field in &ty.fields {
        let base = match &field.ty {
            FieldType::Primitive { primitive, .. } => primitive.ros2().to_owned(),
            FieldType::Struct(name) => format!("{PACKAGE}/{name}"),
        };
        let suffix = if field.is_array { "[]" } else { "" };
        // A vocabulary's words are constants just above their field, as ROS 2 messages
        // write them (`string STATUS_ARRIVED="arrived"`): readers know them; the wire
        // does not change.
        for value in &field.values {
            text.push_str(&format!(
                "string {}=\"{}\"\n",
                value.constant(&field.name),
                value.name
            ));
        }
        text.push_str(&format!("{base}{suffix} {}\n", field.name));
    }
    text
}
