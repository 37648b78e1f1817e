//! The health a service declares of itself, sent with each heartbeat.

use std::fmt;

use serde::{Deserialize, Serialize};

/// The health a service declares with each heartbeat.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Health {
    /// Working as specified.
    #[default]
    Ok,
    /// Working, but worse than usual (shown and recorded; clients stay bound).
    Degraded(String),
    /// Not able to provide its interfaces now (clients are moved to another provider at once).
    OutOfService(String),
}

impl Health {
    /// Whether the service says it cannot serve.
    #[must_use]
    pub fn is_out_of_service(&self) -> bool {
        matches!(self, Self::OutOfService(_))
    }
}

impl fmt::Display for Health {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Ok => write!(f, "ok"),
            Self::Degraded(why) => write!(f, "degraded ({why})"),
            Self::OutOfService(why) => write!(f, "out of service ({why})"),
        }
    }
}
