//! Liveness of the nodes (processes) of a namespace.
//!
//! A publisher killed with SIGKILL is not noticed by its subscribers (its samples simply
//! stop), but its node is reported dead here: iceoryx2 holds a lock per node that the
//! kernel releases when the process dies. Cleaning up removes what the dead node left
//! (its ports in every service, its shared memory).

use iceoryx2::node::{Node, NodeState, NodeView};
use iceoryx2::prelude::{CallbackProgression, ipc};

use super::Ipc;

/// Whether a node's process is alive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum NodeLiveness {
    /// The process holds its node lock.
    Alive,
    /// The process died without removing its node: its resources wait for
    /// [`Ipc::cleanup_dead_nodes`].
    Dead,
    /// This process may not inspect the node (another user's).
    Inaccessible,
    /// The node's files are incomplete (being created or removed right now).
    Undefined,
}

/// One node of the namespace.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct NodeInfo {
    /// The node id, unique on this machine.
    pub id: u128,
    /// Whether its process lives.
    pub liveness: NodeLiveness,
    /// The name it was opened with, when readable.
    pub name: Option<String>,
    /// The process id, when readable.
    pub pid: Option<i32>,
}

/// The result of [`Ipc::cleanup_dead_nodes`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CleanupReport {
    /// Dead nodes whose resources were removed.
    pub cleaned: u64,
    /// Dead nodes that could not be cleaned (permissions, or another process is at it).
    pub failed: u64,
}

/// Why the node list could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "cannot list the IPC nodes of namespace `{namespace}`: {reason}; check the permissions of /tmp/iceoryx2"
)]
pub struct LivenessError {
    /// The namespace.
    pub namespace: String,
    /// What iceoryx2 said.
    pub reason: String,
}

impl Ipc {
    /// Every node of this namespace (this one included), sorted by id.
    pub fn nodes(&self) -> Result<Vec<NodeInfo>, LivenessError> {
        let mut nodes = Vec::new();
        Node::<ipc::Service>::list(self.node().config(), |state| {
            nodes.push(node_info(&state));
            CallbackProgression::Continue
        })
        .map_err(|e| LivenessError {
            namespace: self.namespace().to_string(),
            reason: e.to_string(),
        })?;
        nodes.sort();
        Ok(nodes)
    }

    /// Removes the resources of every dead node of this namespace, without waiting for a
    /// node that another process is cleaning.
    pub fn cleanup_dead_nodes(&self) -> CleanupReport {
        let state = self.node().try_cleanup_dead_nodes();
        CleanupReport {
            cleaned: state.cleanups,
            failed: state.failed_cleanups,
        }
    }
}

fn node_info(state: &NodeState<ipc::Service>) -> NodeInfo {
    let (liveness, details) = match state {
        NodeState::Alive(view) => (NodeLiveness::Alive, view.details().as_ref()),
        NodeState::Dead(view) => (NodeLiveness::Dead, view.details().as_ref()),
        NodeState::Inaccessible(_) => (NodeLiveness::Inaccessible, None),
        NodeState::Undefined(_) => (NodeLiveness::Undefined, None),
    };
    NodeInfo {
        id: state.node_id().value(),
        liveness,
        name: details.map(|d| d.name().as_str().to_owned()),
        pid: details.map(|d| d.process_id().value()),
    }
}
