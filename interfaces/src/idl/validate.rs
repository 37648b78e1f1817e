//! Meaning checks on parsed definitions, and their resolution into the [`Idl`] model.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use super::diagnostic::{Diagnostic, Diagnostics, closest};
use super::model::{
    AllowedValue, Command, Field, FieldType, HEADER_TYPE, INPUT_REF_TYPE, Idl, Interface,
    Primitive, StructKind, StructType, camel_case,
};
use super::parse::{RawDocument, RawField, RawInterface, RawTypes, RawValue, Spanned};

/// A parsed file, ready for validation.
pub(super) struct Parsed {
    pub file: PathBuf,
    pub source: String,
    pub document: RawDocument,
}

const RUST_KEYWORDS: &[&str] = &[
    "as", "async", "await", "break", "const", "continue", "crate", "dyn", "else", "enum", "extern",
    "false", "fn", "for", "gen", "if", "impl", "in", "let", "loop", "match", "mod", "move", "mut",
    "pub", "ref", "return", "self", "static", "struct", "super", "trait", "true", "type", "unsafe",
    "use", "where", "while", "abstract", "become", "box", "do", "final", "macro", "override",
    "priv", "try", "typeof", "unsized", "virtual", "yield",
];

/// Names of a type: its primitive, or that it is a struct.
#[derive(Clone, Copy)]
enum Known {
    Primitive(Primitive),
    Struct,
}

/// Validates every parsed file together and resolves them into an [`Idl`].
pub(super) fn validate(files: &[Parsed]) -> Result<Idl, Diagnostics> {
    let mut errors = Vec::new();
    let mut known: BTreeMap<String, Known> = BTreeMap::new();
    let mut types_xml = Vec::new();
    let mut raw_structs = Vec::new();
    let mut type_files = BTreeSet::new();
    let builtins = Idl::builtin_types();
    for t in &builtins {
        known.insert(t.name.clone(), Known::Struct);
    }

    // Type libraries first: interfaces refer to them.
    for parsed in files {
        let RawDocument::Types(types) = &parsed.document else {
            continue;
        };
        let file = parsed.file.as_path();
        let file_name = file_name(file);
        type_files.insert(file_name.clone());
        types_xml.push((file_name, parsed.source.clone()));
        check_version(file, &types.version, &mut errors);
        collect_type_names(file, types, &mut known, &mut errors);
        raw_structs.extend(types.structs.iter().map(|s| (file, s)));
    }

    let mut types = builtins;
    for (file, raw) in &raw_structs {
        let fields = resolve_fields(file, &raw.fields, &known, &mut errors);
        if raw.fields.is_empty() {
            errors.push(
                Diagnostic::error(
                    file,
                    raw.position,
                    format!("struct `{}` has no fields", raw.name.value),
                )
                .with_hint("add a `<field>`, or remove the struct"),
            );
        }
        types.push(StructType {
            name: raw.name.value.clone(),
            kind: StructKind::Compound,
            description: raw.description.clone(),
            fields,
        });
    }
    check_cycles(&raw_structs, &types, &mut errors);

    let mut interfaces = Vec::new();
    let mut interface_names: BTreeMap<String, PathBuf> = BTreeMap::new();
    for parsed in files {
        let RawDocument::Interface(raw) = &parsed.document else {
            continue;
        };
        let file = parsed.file.as_path();
        if let Some(interface) = resolve_interface(
            file,
            &parsed.source,
            raw,
            &type_files,
            &mut known,
            &mut interface_names,
            &mut errors,
        ) {
            interfaces.push(interface);
        }
    }
    check_vocabulary_names(files, &mut errors);
    if !errors.is_empty() {
        let mut diagnostics = Diagnostics(errors);
        diagnostics.sort();
        return Err(diagnostics);
    }
    interfaces.sort_by(|a, b| a.name.cmp(&b.name));
    Ok(Idl {
        types,
        types_xml,
        interfaces,
    })
}

/// The enum of a field's values takes a type name (`MoverStatus`): one that no struct, no
/// command enum and no other field's values take.
fn check_vocabulary_names(files: &[Parsed], errors: &mut Vec<Diagnostic>) {
    let mut taken: BTreeSet<String> = Idl::builtin_types().into_iter().map(|t| t.name).collect();
    let mut owners: Vec<(&Path, String, &[RawField])> = Vec::new();
    for parsed in files {
        let file = parsed.file.as_path();
        match &parsed.document {
            RawDocument::Types(types) => {
                for s in &types.structs {
                    taken.insert(s.name.value.clone());
                    owners.push((file, s.name.value.clone(), &s.fields));
                }
            }
            RawDocument::Interface(raw) => {
                let name = &raw.name.value;
                taken.extend([
                    name.clone(),
                    format!("{name}Command"),
                    format!("{name}Reply"),
                ]);
                owners.push((file, name.clone(), &raw.publish));
                for c in &raw.commands {
                    let request = format!("{name}{}", camel_case(&c.name.value));
                    let reply = format!("{request}Reply");
                    taken.extend([request.clone(), reply.clone()]);
                    owners.push((file, request, &c.args));
                    owners.push((file, reply, &c.reply));
                }
            }
        }
    }
    for (file, owner, fields) in owners {
        for field in fields.iter().filter(|f| !f.values.is_empty()) {
            let generated = format!("{owner}{}", camel_case(&field.name.value));
            if !taken.insert(generated.clone()) {
                errors.push(
                    Diagnostic::error(
                        file,
                        field.name.position,
                        format!(
                            "the values of `{}` need the type name `{generated}`, which is taken",
                            field.name.value
                        ),
                    )
                    .with_hint("rename the field or the type"),
                );
            }
        }
    }
}

fn file_name(file: &Path) -> String {
    file.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

fn check_version(file: &Path, version: &Spanned, errors: &mut Vec<Diagnostic>) {
    let ok = version
        .value
        .split_once('.')
        .is_some_and(|(major, minor)| is_number(major) && is_number(minor));
    if !ok {
        errors.push(
            Diagnostic::error(
                file,
                version.position,
                format!("bad version `{}`", version.value),
            )
            .with_hint("write MAJOR.MINOR, for example `1.0`"),
        );
    }
}

fn is_number(s: &str) -> bool {
    !s.is_empty() && s.len() <= 9 && s.bytes().all(|b| b.is_ascii_digit())
}

fn is_type_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_ascii_uppercase()) && chars.all(|c| c.is_ascii_alphanumeric())
}

fn is_field_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_ascii_lowercase())
        && name
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
        && !name.ends_with('_')
        && !name.contains("__")
}

fn check_type_name(file: &Path, name: &Spanned, what: &str, errors: &mut Vec<Diagnostic>) -> bool {
    if is_type_name(&name.value) {
        return true;
    }
    errors.push(
        Diagnostic::error(
            file,
            name.position,
            format!("bad {what} name `{}`", name.value),
        )
        .with_hint("type names are CamelCase: a capital letter, then letters and digits"),
    );
    false
}

fn collect_type_names(
    file: &Path,
    types: &RawTypes,
    known: &mut BTreeMap<String, Known>,
    errors: &mut Vec<Diagnostic>,
) {
    let mut declare = |name: &Spanned, kind: Known, errors: &mut Vec<Diagnostic>| {
        if name.value == HEADER_TYPE || name.value == INPUT_REF_TYPE {
            errors.push(
                Diagnostic::error(
                    file,
                    name.position,
                    format!("`{}` is a built-in type", name.value),
                )
                .with_hint("every message starts with the built-in Header; choose another name"),
            );
        } else if known.contains_key(&name.value) {
            errors.push(Diagnostic::error(
                file,
                name.position,
                format!("duplicate type name `{}`", name.value),
            ));
        } else {
            known.insert(name.value.clone(), kind);
        }
    };
    for primitive in &types.primitives {
        if !check_type_name(file, &primitive.name, "type", errors) {
            continue;
        }
        match Primitive::from_ros2(&primitive.ros2.value) {
            Some(p) => declare(&primitive.name, Known::Primitive(p), errors),
            None => {
                let spellings: Vec<&str> = Primitive::ALL.iter().map(|(_, n)| *n).collect();
                let d = Diagnostic::error(
                    file,
                    primitive.ros2.position,
                    format!("unknown ROS 2 type `{}`", primitive.ros2.value),
                );
                errors.push(
                    match closest(&primitive.ros2.value, spellings.iter().copied()) {
                        Some(near) => d.with_hint(format!("did you mean `{near}`?")),
                        None => d.with_hint(format!("one of: {}", spellings.join(", "))),
                    },
                );
            }
        }
    }
    for s in &types.structs {
        if check_type_name(file, &s.name, "struct", errors) {
            declare(&s.name, Known::Struct, errors);
        }
    }
}

fn resolve_fields(
    file: &Path,
    raw: &[RawField],
    known: &BTreeMap<String, Known>,
    errors: &mut Vec<Diagnostic>,
) -> Vec<Field> {
    let mut fields: Vec<Field> = Vec::new();
    let mut seen: BTreeMap<&str, usize> = BTreeMap::new();
    for (index, f) in raw.iter().enumerate() {
        let name = &f.name.value;
        if !is_field_name(name) {
            errors.push(
                Diagnostic::error(file, f.name.position, format!("bad field name `{name}`"))
                    .with_hint("field names are snake_case: lower-case letters, digits and single underscores, starting with a letter"),
            );
        } else if RUST_KEYWORDS.contains(&name.as_str()) {
            errors.push(
                Diagnostic::error(
                    file,
                    f.name.position,
                    format!("field name `{name}` is a Rust keyword"),
                )
                .with_hint("choose another name, for example with a unit or a qualifier"),
            );
        } else if name == "header" {
            errors.push(
                Diagnostic::error(file, f.name.position, "field name `header` is reserved")
                    .with_hint(
                        "every message starts with the built-in header; choose another name",
                    ),
            );
        }
        if seen.insert(name, index).is_some() {
            errors.push(Diagnostic::error(
                file,
                f.name.position,
                format!("duplicate field name `{name}`"),
            ));
        }
        let ty = match known.get(&f.ty.value) {
            Some(Known::Primitive(p)) => Some(FieldType::Primitive {
                idl_name: f.ty.value.clone(),
                primitive: *p,
            }),
            Some(Known::Struct) => Some(FieldType::Struct(f.ty.value.clone())),
            None => {
                let d = Diagnostic::error(
                    file,
                    f.ty.position,
                    format!("unknown type `{}`", f.ty.value),
                );
                errors.push(
                    match closest(&f.ty.value, known.keys().map(String::as_str)) {
                        Some(near) => d.with_hint(format!("did you mean `{near}`?")),
                        None => d.with_hint(format!(
                            "known types: {}",
                            known
                                .keys()
                                .map(String::as_str)
                                .collect::<Vec<_>>()
                                .join(", ")
                        )),
                    },
                );
                None
            }
        };
        if let Some(size) = &f.array_size {
            check_array_size(file, f, size, raw, index, known, errors);
            if matches!(
                ty,
                Some(FieldType::Primitive {
                    primitive: Primitive::Bytes,
                    ..
                })
            ) {
                errors.push(
                    Diagnostic::error(
                        file,
                        size.position,
                        format!("`{name}` is an array of Bytes"),
                    )
                    .with_hint("Bytes is already a sequence; an array of them is not a ROS 2 type"),
                );
            }
        }
        let values = resolve_values(file, f, ty.as_ref(), errors);
        if let Some(ty) = ty {
            fields.push(Field {
                name: name.clone(),
                ty,
                is_array: f.array_size.is_some(),
                array_size: f.array_size.as_ref().map(|s| s.value.clone()),
                unit: f.unit.clone(),
                description: f.description.clone(),
                values,
            });
        }
    }
    check_constants(file, raw, errors);
    fields
}

/// A value is lower-case words of letters and digits, each word starting with a letter,
/// joined by single `-` or `_`: so that it makes both a Rust variant and a ros2msg
/// constant name.
fn is_value_name(name: &str) -> bool {
    name.split(['-', '_']).all(|word| {
        word.chars().next().is_some_and(|c| c.is_ascii_lowercase())
            && word
                .chars()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit())
    })
}

/// The `<value>`s of a field: only on String fields, each a good word, none twice, no two
/// giving one Rust variant.
fn resolve_values(
    file: &Path,
    field: &RawField,
    ty: Option<&FieldType>,
    errors: &mut Vec<Diagnostic>,
) -> Vec<AllowedValue> {
    let Some(first) = field.values.first() else {
        return Vec::new();
    };
    let name = &field.name.value;
    let is_string = matches!(
        ty,
        Some(FieldType::Primitive {
            primitive: Primitive::String,
            ..
        })
    );
    if !is_string {
        if ty.is_some() {
            errors.push(
                Diagnostic::error(
                    file,
                    first.name.position,
                    format!(
                        "`<value>` on `{name}`, a field of type `{}`",
                        field.ty.value
                    ),
                )
                .with_hint("only String fields take values"),
            );
        }
        return Vec::new();
    }
    let mut values: Vec<AllowedValue> = Vec::new();
    let mut variants: BTreeMap<String, &RawValue> = BTreeMap::new();
    for raw in &field.values {
        let word = &raw.name.value;
        if !is_value_name(word) || word == "self" {
            errors.push(
                Diagnostic::error(
                    file,
                    raw.name.position,
                    format!("bad value `{word}` of `{name}`"),
                )
                .with_hint(if word == "self" {
                    "`self` makes the variant `Self`, a Rust keyword: choose another word"
                } else {
                    "values are lower-case words of letters and digits, each starting with a letter, joined by `-` or `_`"
                }),
            );
            continue;
        }
        let value = AllowedValue {
            name: word.clone(),
            description: raw.description.clone(),
        };
        match variants.get(&value.variant()) {
            Some(earlier) if earlier.name.value == *word => errors.push(Diagnostic::error(
                file,
                raw.name.position,
                format!("duplicate value `{word}` of `{name}`"),
            )),
            Some(earlier) => errors.push(
                Diagnostic::error(
                    file,
                    raw.name.position,
                    format!(
                        "values `{}` and `{word}` of `{name}` both make the variant `{}`",
                        earlier.name.value,
                        value.variant()
                    ),
                )
                .with_hint("`-` and `_` join words alike: choose another word"),
            ),
            None => {
                variants.insert(value.variant(), raw);
                values.push(value);
            }
        }
    }
    values
}

/// The ros2msg constants of one struct's fields are unique: `a_b` with `c` and `a` with
/// `b_c` would both make `A_B_C`.
fn check_constants(file: &Path, raw: &[RawField], errors: &mut Vec<Diagnostic>) {
    let mut constants: BTreeMap<String, &str> = BTreeMap::new();
    for field in raw {
        for value in &field.values {
            if !is_value_name(&value.name.value) {
                continue;
            }
            let constant = AllowedValue {
                name: value.name.value.clone(),
                description: None,
            }
            .constant(&field.name.value);
            match constants.get(constant.as_str()) {
                Some(other) if *other != field.name.value => errors.push(
                    Diagnostic::error(
                        file,
                        value.name.position,
                        format!(
                            "value `{}` of `{}` makes the constant `{constant}`, as a value of `{other}` does",
                            value.name.value, field.name.value
                        ),
                    )
                    .with_hint("rename the field or the value"),
                ),
                _ => {
                    constants.insert(constant, &field.name.value);
                }
            }
        }
    }
}

fn check_array_size(
    file: &Path,
    field: &RawField,
    size: &Spanned,
    all: &[RawField],
    index: usize,
    known: &BTreeMap<String, Known>,
    errors: &mut Vec<Diagnostic>,
) {
    let name = &field.name.value;
    let target = all.iter().position(|f| f.name.value == size.value);
    let Some(at) = target else {
        let d = Diagnostic::error(
            file,
            size.position,
            format!("array_size `{}` of `{name}` names no field", size.value),
        );
        let earlier = all.get(..index).unwrap_or_default();
        errors.push(
            match closest(&size.value, earlier.iter().map(|f| f.name.value.as_str())) {
                Some(near) => d.with_hint(format!("did you mean `{near}`?")),
                None => {
                    d.with_hint("declare an Integer field that holds the length before the array")
                }
            },
        );
        return;
    };
    let target = &all[at];
    if at >= index {
        errors.push(
            Diagnostic::error(
                file,
                size.position,
                format!(
                    "array_size `{}` of `{name}` names a later field",
                    size.value
                ),
            )
            .with_hint(format!(
                "move `{}` above `{name}`: a length comes before its array",
                size.value
            )),
        );
        return;
    }
    let is_integer =
        matches!(known.get(&target.ty.value), Some(Known::Primitive(p)) if p.is_integer());
    if !is_integer || target.array_size.is_some() {
        errors.push(
            Diagnostic::error(
                file,
                size.position,
                format!(
                    "array_size `{}` of `{name}` names a field of type `{}`{}",
                    size.value,
                    target.ty.value,
                    if target.array_size.is_some() {
                        " array"
                    } else {
                        ""
                    }
                ),
            )
            .with_hint("array_size must name a single Integer field"),
        );
    }
}

fn check_cycles(
    raw: &[(&Path, &super::parse::RawStruct)],
    types: &[StructType],
    errors: &mut Vec<Diagnostic>,
) {
    let by_name: BTreeMap<&str, &StructType> = types.iter().map(|t| (t.name.as_str(), t)).collect();
    for (file, s) in raw {
        // Depth-first from each struct: reaching it again is a cycle. Bounded by the
        // number of types, since each is visited once per start.
        let mut stack = vec![s.name.value.as_str()];
        let mut visited = BTreeSet::new();
        while let Some(name) = stack.pop() {
            let Some(t) = by_name.get(name) else { continue };
            for field in &t.fields {
                if let FieldType::Struct(inner) = &field.ty {
                    if *inner == s.name.value {
                        errors.push(
                            Diagnostic::error(
                                file,
                                s.position,
                                format!(
                                    "struct `{}` contains itself (through `{}`)",
                                    s.name.value, t.name
                                ),
                            )
                            .with_hint("a message has a fixed shape: break the cycle"),
                        );
                        stack.clear();
                        break;
                    }
                    if visited.insert(inner.as_str()) {
                        stack.push(inner.as_str());
                    }
                }
            }
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn resolve_interface(
    file: &Path,
    source: &str,
    raw: &RawInterface,
    type_files: &BTreeSet<String>,
    known: &mut BTreeMap<String, Known>,
    interface_names: &mut BTreeMap<String, PathBuf>,
    errors: &mut Vec<Diagnostic>,
) -> Option<Interface> {
    let before = errors.len();
    let name = &raw.name.value;
    if check_type_name(file, &raw.name, "interface", errors) {
        let stem = file.file_stem().map(|s| s.to_string_lossy().into_owned());
        if stem.as_deref() != Some(name.as_str()) {
            errors.push(
                Diagnostic::error(
                    file,
                    raw.name.position,
                    format!(
                        "interface `{name}` is in a file named `{}`",
                        file_name(file)
                    ),
                )
                .with_hint(format!(
                    "name the file `{name}.xml`, so tools find it by name"
                )),
            );
        }
        if let Some(other) = interface_names.insert(name.clone(), file.to_path_buf()) {
            errors.push(Diagnostic::error(
                file,
                raw.name.position,
                format!("interface `{name}` is also defined in {}", other.display()),
            ));
        } else if known.contains_key(name) {
            errors.push(
                Diagnostic::error(
                    file,
                    raw.name.position,
                    format!("interface `{name}` has the name of a type"),
                )
                .with_hint("interfaces and types share one namespace: rename one of them"),
            );
        }
    }
    check_version(file, &raw.version, errors);
    match &raw.types_file {
        None => errors.push(
            Diagnostic::error(
                file,
                raw.position,
                format!("interface `{name}` has no `<types filename=...>`"),
            )
            .with_hint("add `<types filename=\"types.xml\"/>` naming the type library it uses"),
        ),
        Some(t) if !type_files.contains(&t.value) => errors.push(
            Diagnostic::error(
                file,
                t.position,
                format!("type library `{}` not found", t.value),
            )
            .with_hint(format!(
                "put it beside this file; found: {}",
                if type_files.is_empty() {
                    "none".to_owned()
                } else {
                    type_files.iter().cloned().collect::<Vec<_>>().join(", ")
                }
            )),
        ),
        Some(_) => {}
    }

    let publication = StructType {
        name: name.clone(),
        kind: StructKind::Publication {
            interface: name.clone(),
        },
        description: raw.description.clone(),
        fields: resolve_fields(file, &raw.publish, known, errors),
    };
    let mut commands = Vec::new();
    let mut command_names = BTreeSet::new();
    for c in &raw.commands {
        let cname = &c.name.value;
        if !is_field_name(cname) {
            errors.push(
                Diagnostic::error(file, c.name.position, format!("bad command name `{cname}`"))
                    .with_hint("command names are snake_case, like `set_zoom`"),
            );
        }
        if !command_names.insert(cname.as_str()) {
            errors.push(Diagnostic::error(
                file,
                c.name.position,
                format!("duplicate command `{cname}` in interface `{name}`"),
            ));
        }
        let request_name = format!("{name}{}", camel_case(cname));
        let reply_name = format!("{request_name}Reply");
        for generated in [&request_name, &reply_name] {
            if known.contains_key(generated) {
                errors.push(
                    Diagnostic::error(
                        file,
                        c.name.position,
                        format!(
                            "command `{cname}` needs the type name `{generated}`, which is taken"
                        ),
                    )
                    .with_hint("rename the command or the type"),
                );
            }
        }
        commands.push(Command {
            name: cname.clone(),
            description: c.description.clone(),
            request: StructType {
                name: request_name,
                kind: StructKind::Command {
                    interface: name.clone(),
                    command: cname.clone(),
                },
                description: c.description.clone(),
                fields: resolve_fields(file, &c.args, known, errors),
            },
            reply: StructType {
                name: reply_name,
                kind: StructKind::Reply {
                    interface: name.clone(),
                    command: cname.clone(),
                },
                description: Some(format!("The reply to `{name}.{cname}`.")),
                fields: resolve_fields(file, &c.reply, known, errors),
            },
        });
    }
    if errors.len() > before {
        return None;
    }
    // Reserve the generated names, so a later interface cannot collide with them.
    known.insert(name.clone(), Known::Struct);
    for c in &commands {
        known.insert(c.request.name.clone(), Known::Struct);
        known.insert(c.reply.name.clone(), Known::Struct);
    }
    Some(Interface {
        name: name.clone(),
        version: raw.version.value.clone(),
        description: raw.description.clone(),
        file: file.to_path_buf(),
        position: raw.position,
        xml: source.to_owned(),
        publication,
        commands,
    })
}
