//! What a conversion did, for people (`Display`) and for tests (the fields).

use std::collections::BTreeMap;
use std::fmt;
use std::path::PathBuf;

use crate::{Counts, MapStatus, Target};

/// What [`crate::view`] did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ViewReport {
    /// The recordings read.
    pub inputs: Vec<PathBuf>,
    /// Where the data went.
    pub target: Target,
    /// Channels with messages, over all inputs.
    pub channels: usize,
    /// How many messages went where.
    pub counts: Counts,
    /// Camera frames left out ([`crate::CameraFrames::every_ns`]).
    pub frames_skipped: u64,
    /// Rows logged per Rerun entity path.
    pub entities: BTreeMap<String, u64>,
    /// Per topic: messages that could not be decoded, and the first reason.
    pub failures: BTreeMap<String, (u64, String)>,
    /// Inputs that end in damage (a writer that died), with what the reader met.
    pub damage: Vec<(PathBuf, String)>,
    /// The world map, when the recording names a simulated world.
    pub map: Option<MapStatus>,
}

impl fmt::Display for ViewReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = self.counts;
        writeln!(
            f,
            "{} messages on {} channels: {} drawn, {} shown generically, {} not decodable; {} entities",
            c.messages,
            self.channels,
            c.drawn,
            c.generic,
            c.failed,
            self.entities.len()
        )?;
        if self.frames_skipped > 0 {
            writeln!(
                f,
                "  {} camera frames left out (--camera-every)",
                self.frames_skipped
            )?;
        }
        for (topic, (count, reason)) in &self.failures {
            writeln!(f, "  {topic}: {count} messages not decodable: {reason}")?;
        }
        for (path, reason) in &self.damage {
            writeln!(
                f,
                "  {} is damaged, shown up to: {reason} (`lewis recover` repairs it)",
                path.display()
            )?;
        }
        if let Some(map) = &self.map {
            writeln!(f, "{map}")?;
        }
        match &self.target {
            Target::Save(path) => writeln!(f, "wrote {}", path.display()),
            Target::Spawn { port } => {
                writeln!(
                    f,
                    "sent to the Rerun viewer on port {port} (started if none was)"
                )
            }
            Target::Connect(address) => writeln!(f, "sent to the Rerun viewer at {address}"),
        }
    }
}
