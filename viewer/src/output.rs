//! Where the Rerun data goes: an .rrd file written here, or a viewer over gRPC.
//!
//! The file is written with Rerun's encoder directly (not through a `RecordingStream`), so
//! that every id in it comes from the input: the same recording always gives the same
//! messages, byte for byte. The file ends with Rerun's footer (the manifest of each store,
//! which `rerun rrd verify` and lazy loading need); Rerun lists the two stores' manifests
//! (recording and blueprint) in hash-map order, so only the footer's bytes may differ
//! between two conversions of one recording.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use rerun::external::re_log_encoding::{Encoder, EncodingOptions};
use rerun::external::re_log_types::{
    BlueprintActivationCommand, LogMsg, SetStoreInfo, StoreInfo, StoreSource,
};
use rerun::external::re_tuid::Tuid;
use rerun::log::Chunk;
use rerun::{RecordingStream, RecordingStreamBuilder, StoreId, StoreKind};

use crate::ViewError;
use crate::rows::ChunkSink;

/// The Rerun application id of every recording `lewis view` makes.
pub const APPLICATION_ID: &str = "lewis";

/// A store's identity, from the input names.
pub(crate) fn store_id(kind: StoreKind, recording_id: &str) -> StoreId {
    StoreId::new(kind, APPLICATION_ID, recording_id)
}

fn set_store_info(store_id: StoreId, tuid: u128) -> LogMsg {
    LogMsg::SetStoreInfo(SetStoreInfo {
        row_id: Tuid::from_u128(tuid),
        info: StoreInfo::new(store_id, StoreSource::Other("lewis view".to_owned())),
    })
}

/// Waits until the viewer behind `stream` is connected, or says why it cannot be. The SDK
/// queues a bounded number of messages while it connects and then blocks the sender: with
/// no viewer there, a recording of more than that many chunks would wait forever.
fn reachable(stream: &RecordingStream, address: &str) -> Result<(), ViewError> {
    stream.flush_blocking().map_err(|e| ViewError::Connect {
        address: address.to_owned(),
        detail: e.to_string(),
    })
}

/// An open output.
pub(crate) enum Output {
    /// An .rrd file.
    File {
        path: PathBuf,
        store_id: StoreId,
        encoder: Encoder<BufWriter<File>>,
    },
    /// A viewer, spawned or reached at an address.
    Viewer {
        address: String,
        stream: RecordingStream,
    },
}

impl Output {
    /// Creates the file at `path` (replacing it).
    pub(crate) fn file(path: &Path, recording_id: &str) -> Result<Self, ViewError> {
        let write_error = |detail: String| ViewError::Write {
            path: path.to_owned(),
            detail,
        };
        let file = File::create(path).map_err(|e| write_error(e.to_string()))?;
        let mut encoder = Encoder::new_eager(
            rerun::external::re_build_info::CrateVersion::LOCAL,
            EncodingOptions::PROTOBUF_COMPRESSED,
            BufWriter::new(file),
        )
        .map_err(|e| write_error(e.to_string()))?;
        let store_id = store_id(StoreKind::Recording, recording_id);
        encoder
            .append(&set_store_info(store_id.clone(), 1))
            .map_err(|e| write_error(e.to_string()))?;
        Ok(Self::File {
            path: path.to_owned(),
            store_id,
            encoder,
        })
    }

    /// Starts a viewer (the `rerun` binary on the PATH) on `port` and connects to it; a
    /// process already listening there is taken for a viewer and used.
    pub(crate) fn spawn(recording_id: &str, port: u16) -> Result<Self, ViewError> {
        let options = rerun::SpawnOptions {
            port,
            // A viewer starting on a busy machine takes longer than the connection's own
            // patience (5 s); waiting for its port first makes the start reliable.
            wait_for_bind: true,
            ..rerun::SpawnOptions::default()
        };
        let stream = RecordingStreamBuilder::new(APPLICATION_ID)
            .recording_id(recording_id)
            .spawn_opts(&options)
            .map_err(|e| ViewError::Spawn {
                detail: e.to_string(),
            })?;
        let address = format!("the Rerun viewer on port {port}");
        reachable(&stream, &address)?;
        Ok(Self::Viewer { address, stream })
    }

    /// Connects to a running viewer at `address` (`rerun+http://127.0.0.1:9876/proxy`).
    pub(crate) fn connect(address: &str, recording_id: &str) -> Result<Self, ViewError> {
        let stream = RecordingStreamBuilder::new(APPLICATION_ID)
            .recording_id(recording_id)
            .connect_grpc_opts(address)
            .map_err(|e| ViewError::Connect {
                address: address.to_owned(),
                detail: e.to_string(),
            })?;
        reachable(&stream, address)?;
        Ok(Self::Viewer {
            address: address.to_owned(),
            stream,
        })
    }

    /// Sends the layout and closes the output (the file is complete when this returns).
    pub(crate) fn finish(
        self,
        blueprint: Vec<LogMsg>,
        activation: BlueprintActivationCommand,
    ) -> Result<(), ViewError> {
        match self {
            Self::File {
                path, mut encoder, ..
            } => {
                let write_error = |detail: String| ViewError::Write {
                    path: path.clone(),
                    detail,
                };
                for message in &blueprint {
                    encoder
                        .append(message)
                        .map_err(|e| write_error(e.to_string()))?;
                }
                encoder
                    .append(&LogMsg::BlueprintActivationCommand(activation))
                    .map_err(|e| write_error(e.to_string()))?;
                encoder.finish().map_err(|e| write_error(e.to_string()))?;
                let mut writer = encoder
                    .into_inner()
                    .map_err(|e| write_error(e.to_string()))?;
                writer.flush().map_err(|e| write_error(e.to_string()))?;
                writer
                    .get_ref()
                    .sync_all()
                    .map_err(|e| write_error(e.to_string()))
            }
            Self::Viewer { address, stream } => {
                stream.send_blueprint(blueprint, activation);
                stream.flush_blocking().map_err(|e| ViewError::Connect {
                    address,
                    detail: e.to_string(),
                })
            }
        }
    }
}

impl ChunkSink for Output {
    fn chunk(&mut self, chunk: Chunk) -> Result<(), ViewError> {
        match self {
            Self::File {
                path,
                store_id,
                encoder,
            } => {
                let message = chunk.to_arrow_msg().map_err(|e| ViewError::Build {
                    entity: chunk.entity_path().to_string(),
                    detail: e.to_string(),
                })?;
                encoder
                    .append(&LogMsg::ArrowMsg(store_id.clone(), message))
                    .map(|_| ())
                    .map_err(|e| ViewError::Write {
                        path: path.clone(),
                        detail: e.to_string(),
                    })
            }
            Self::Viewer { stream, .. } => {
                stream.send_chunk(chunk);
                Ok(())
            }
        }
    }
}
