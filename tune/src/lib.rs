//! The tuning workbench behind `lewis tune`: offline tuning of colour classes on recorded or
//! saved images.
//!
//! - `lewis tune blobfinder RUN.mcap|IMAGES --colors FILE [--channel TOPIC] [-o OUT.mcap]
//!   [--png DIR] [--signs]` re-runs CMVision with the colour file (and, with `--signs`, the
//!   sign detector, whose board and arrow classes are the file's `White` and `Black`) over
//!   the ImageSource messages of a recording (or the PNG and JPEG files of a folder or
//!   glob), prints per-colour statistics, and with `-o` writes an MCAP file, through the
//!   recorder, that holds the images unchanged and the results on their own channels
//!   (`/tune/blobfinder/Blobs`, `/tune/sign_detector/Signs`), each result naming its image
//!   in its provenance: `lewis view OUT.mcap` draws them over the images. `--png DIR`
//!   writes each frame with its blobs drawn in as PNG instead (or as well).
//! - `lewis tune pick IMAGE|RUN.mcap@T [X,Y] [--rect X,Y,W,H]` prints the YUV ranges of a
//!   patch of pixels of an image file, or of the recorded image shown at T seconds into a
//!   recording, as the two lines of a Player colour file.
//! - `lewis tune check RUN.mcap|IMAGES --colors FILE --labels FILE.json` scores the colour
//!   file's blobs against labelled frames (precision and recall per class) and exits 1
//!   below `--min-precision`/`--min-recall` (`check.rs`).
//! - `lewis tune fit RUN.mcap|IMAGES --colors START --labels FILE.json -o OUT` fits the
//!   labelled classes' ranges to the labels (`fit.rs`).
//! - `lewis tune label-sim RUN.mcap -o FILE.json` labels a simulator recording's frames
//!   from the simulator's ground truth (`label_sim.rs`).
//! - `lewis tune open RUN.mcap|IMAGES --colors FILE [--labels FILE.json]` serves the tuning
//!   page on 127.0.0.1 (`open/`), where boxes labelled by hand are saved for `check` and
//!   `fit`.
//!
//! The perception work is done by `lewis_perception::tuning`; recordings are read
//! with `lewis_recording` and written with `lewis_recorder`. This crate wires them.
//! Each command's options are its clap arguments (`lewis tune`'s subcommands take them as
//! they are); each command returns what it found, as a report whose `Display` is what
//! `lewis tune` prints, and the `lewis` command prints it.

mod blobfinder;
mod check;
mod fit;
mod frames;
mod label_sim;
mod open;
mod output;
mod pick;

pub use blobfinder::{BlobfinderArgs, BlobfinderReport, blobfinder};
pub use check::{CheckArgs, CheckReport, check};
pub use fit::{FitArgs, FitReport, fit};
pub use label_sim::{DEFAULT_MIN_PIXELS, LabelSimArgs, LabelSimReport, label_sim};
pub use open::{OpenArgs, TuningPage, open};
pub use pick::{PickArgs, PickReport, Source, pick};
