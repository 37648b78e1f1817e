//! Importers: logs of other robot software turned into Lewis messages, with times, for the
//! recorder to write as a Lewis recording that replay can run services over.

pub mod carmen;
