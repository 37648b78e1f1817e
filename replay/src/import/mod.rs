//! Importers: logs of other robot software turned into Lewis messages, with times, and
//! written as a Lewis recording that replay can run services over.
//!
//! - [`carmen`]: CARMEN logs (the Radish data sets) as a stream of messages and a robot.
//! - [`record`]: an import written through the recorder (`lewis import carmen`).

pub mod carmen;
pub mod record;
