//! Finding the robot of a namespace from its broker: `lewis record` without `--robot` asks
//! the broker (`robot` on `/lewis/broker/cmd`) which robot description it runs, then taps
//! every channel of that robot (all its providers, also those a failover starts later) and
//! stores the description in the file.
//!
//! A broker that is not there yet is asked again every [`ASK_PERIOD`] (nothing announces a
//! broker), without ever making the tap wait: the question is sent, and its answer taken
//! when it has come. Once a robot is found, it is kept: the recorder is not asked to follow
//! another robot started later in the same namespace.

use std::path::Path;
use std::time::{Duration, Instant};

use lewis_interfaces::Command;
use lewis_interfaces::cdr;
use lewis_interfaces::msg::{BrokerRobot, BrokerRobotReply};
use lewis_robot::Robot;
use lewis_runtime::ipc::{CallError, CallId, CommandClient, Ipc, IpcError, Waitable};
use lewis_runtime::names;
use lewis_service::wire;

use crate::options::RobotDescription;

/// Between two questions to a broker that has not answered.
pub const ASK_PERIOD: Duration = Duration::from_millis(500);

/// How long a broker has to answer one question.
const ANSWER_TIMEOUT: Duration = Duration::from_secs(2);

/// A robot found from its broker.
#[derive(Debug, Clone)]
pub struct Discovered {
    /// The robot, parsed and checked against the compiled interfaces.
    pub robot: Robot,
    /// Its description as the broker read it (stored in the file as `lewis.robot`).
    pub description: RobotDescription,
}

/// Asks the broker of a namespace for its robot until it answers.
pub struct Discovery {
    client: CommandClient,
    pending: Option<CallId>,
    next_ask: Instant,
    /// Set once a robot is found, or once the broker's answer proved unusable.
    done: bool,
}

impl Discovery {
    /// A discovery through `ipc`'s namespace; it asks nothing yet.
    ///
    /// # Errors
    /// When the broker's command channel cannot be opened.
    pub fn new(ipc: &Ipc) -> Result<Self, IpcError> {
        Ok(Self {
            client: ipc.command_client(names::BROKER_COMMAND, &names::broker_command_config())?,
            pending: None,
            next_ask: Instant::now(),
            done: false,
        })
    }

    /// Asks once and waits for the answer (at most `ANSWER_TIMEOUT`); `None` when no
    /// broker answers (then [`Discovery::poll`] asks again later).
    pub fn ask_and_wait(&mut self) -> Option<Discovered> {
        let frame = request_frame();
        let answer = self.client.call_blocking(
            frame.len(),
            ANSWER_TIMEOUT,
            |buf| buf.copy_from_slice(&frame),
            lewis_runtime::ipc::WakeMode::Event,
        );
        self.next_ask = Instant::now() + ASK_PERIOD;
        match answer {
            Ok(reply) => self.take(reply.bytes()),
            Err(CallError::NoServer { .. }) => None,
            Err(e) => {
                tracing::warn!("the broker did not say which robot it runs: {e}");
                None
            }
        }
    }

    /// Asks when due and takes the answer when it has come, never waiting; `Some` once,
    /// when the robot is found.
    pub fn poll(&mut self, now: Instant) -> Option<Discovered> {
        if self.done {
            return None;
        }
        if let Some(call) = self.pending {
            match self.client.outcome_of(call)? {
                Ok(reply) => {
                    self.pending = None;
                    return self.take(reply.bytes());
                }
                Err(e) => {
                    self.pending = None;
                    tracing::debug!("no answer from the broker yet: {e}");
                }
            }
        }
        if self.pending.is_none() && now >= self.next_ask {
            self.next_ask = now + ASK_PERIOD;
            match self.client.call(&request_frame(), ANSWER_TIMEOUT) {
                Ok(call) => self.pending = Some(call),
                // No broker yet: ask again later.
                Err(CallError::NoServer { .. }) => {}
                Err(e) => tracing::debug!("cannot ask the broker for its robot: {e}"),
            }
        }
        None
    }

    /// When the next question is due, while none is out.
    #[must_use]
    pub fn next_ask(&self) -> Option<Instant> {
        (!self.done && self.pending.is_none()).then_some(self.next_ask)
    }

    /// The client to wait on while a question is out (its answer wakes the loop).
    #[must_use]
    pub fn waitable(&self) -> Option<&dyn Waitable> {
        (!self.done && self.pending.is_some()).then_some(&self.client as &dyn Waitable)
    }

    /// Reads the broker's answer; the search ends either way but for a refusal.
    fn take(&mut self, frame: &[u8]) -> Option<Discovered> {
        match read_answer(frame) {
            Ok(found) => {
                self.done = true;
                Some(found)
            }
            Err(Unusable::Refused(reason)) => {
                // A broker of another build that does not know the question: keep trying
                // would only repeat the refusal.
                self.done = true;
                tracing::error!(
                    "the broker does not say which robot it runs ({reason}): give --robot to record the robot's services"
                );
                None
            }
            Err(Unusable::Bad(reason)) => {
                self.done = true;
                tracing::error!(
                    "the broker's robot description cannot be used: {reason}; give --robot to record the robot's services"
                );
                None
            }
        }
    }
}

/// Why an answer of the broker gave no robot.
#[derive(Debug)]
enum Unusable {
    Refused(String),
    Bad(String),
}

fn request_frame() -> Vec<u8> {
    wire::request_to_vec(BrokerRobot::NAME, &cdr::to_vec(&BrokerRobot::default()))
}

/// The robot in a reply frame of `robot`.
fn read_answer(frame: &[u8]) -> Result<Discovered, Unusable> {
    let bytes = wire::read_reply(frame)
        .map_err(|e| Unusable::Bad(e.to_string()))?
        .map_err(Unusable::Refused)?;
    let reply: BrokerRobotReply =
        cdr::from_bytes(bytes).map_err(|e| Unusable::Bad(e.to_string()))?;
    let known: Vec<&str> = lewis_interfaces::msg::INTERFACES
        .iter()
        .map(|i| i.name)
        .collect();
    let file_name = if reply.file_name.is_empty() {
        "robot.toml".to_owned()
    } else {
        reply.file_name
    };
    let robot = lewis_robot::parse(&reply.toml, Path::new(&file_name), &known)
        .map_err(|e| Unusable::Bad(e.to_string()))?;
    Ok(Discovered {
        robot,
        description: RobotDescription {
            file_name,
            toml: reply.toml,
        },
    })
}

#[cfg(test)]
mod tests {
    use lewis_interfaces::msg::BrokerRobotReply;

    use super::*;

    fn frame(reply: &Result<BrokerRobotReply, String>) -> Vec<u8> {
        wire::reply_to_vec(&reply.as_ref().map(cdr::to_vec).map_err(Clone::clone))
    }

    #[test]
    fn an_answer_gives_the_robot_and_its_text_unchanged() {
        let toml = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../robots/test.toml"),
        )
        .unwrap();
        let found = read_answer(&frame(&Ok(BrokerRobotReply {
            file_name: "test.toml".into(),
            toml: toml.clone(),
            ..BrokerRobotReply::default()
        })))
        .unwrap();
        assert_eq!(found.robot.name, "test");
        assert_eq!(found.description.file_name, "test.toml");
        assert_eq!(found.description.toml, toml);
    }

    #[test]
    fn a_bad_description_or_a_refusal_is_said_not_panicked() {
        let bad = read_answer(&frame(&Ok(BrokerRobotReply {
            file_name: "x.toml".into(),
            toml: "[robot\n".into(),
            ..BrokerRobotReply::default()
        })));
        assert!(
            matches!(&bad, Err(Unusable::Bad(reason)) if reason.contains("x.toml")),
            "{bad:?}"
        );
        let refused = read_answer(&frame(&Err("unknown command robot".into())));
        assert!(
            matches!(&refused, Err(Unusable::Refused(r)) if r == "unknown command robot"),
            "{refused:?}"
        );
        assert!(matches!(read_answer(b"junk"), Err(Unusable::Bad(_))));
    }
}
