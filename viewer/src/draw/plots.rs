//! Every numeric field of a message as a plot: `plots/<topic>/<field>`. Fields inside
//! arrays are left out (a scan's ranges are drawn, not plotted), and so is the common
//! header (sequence numbers and send times are not worth a plot).

use lewis_interfaces::dynamic::Value;
use rerun::Scalars;

use super::{entity, topic_parts};
use crate::ViewError;
use crate::rows::{ChunkSink, Rows, Stamp};

/// Logs one scalar per numeric field of `value` (booleans as 0 and 1); says whether there
/// was any.
pub(super) fn log_numeric_fields(
    rows: &mut Rows,
    sink: &mut dyn ChunkSink,
    topic: &str,
    stamp: Stamp,
    value: &Value,
) -> Result<bool, ViewError> {
    let mut fields = Vec::new();
    if let Value::Struct(members) = value {
        for (name, member) in members {
            if &**name != "header" {
                collect(member, &mut vec![name.to_string()], &mut fields);
            }
        }
    }
    let any = !fields.is_empty();
    for (path, number) in fields {
        let parts = std::iter::once("plots")
            .chain(topic_parts(topic))
            .chain(path.iter().map(String::as_str));
        rows.log(sink, &entity(parts), stamp, &Scalars::single(number), 16)?;
    }
    Ok(any)
}

fn collect(value: &Value, path: &mut Vec<String>, out: &mut Vec<(Vec<String>, f64)>) {
    let number = match value {
        Value::Bool(b) => Some(f64::from(u8::from(*b))),
        Value::Int(i) => Some(*i as f64),
        Value::UInt(u) => Some(*u as f64),
        Value::Float(f) => Some(*f),
        Value::Struct(members) => {
            for (name, member) in members {
                path.push(name.to_string());
                collect(member, path, out);
                path.pop();
            }
            None
        }
        Value::String(_) | Value::Bytes(_) | Value::Array(_) => None,
    };
    if let Some(number) = number.filter(|n| n.is_finite()) {
        out.push((path.clone(), number));
    }
}
