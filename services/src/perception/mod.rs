//! Perception: colour segmentation (CMVision) and what is built on it.

pub mod cmvision;

pub use cmvision::{
    ChannelRange, CmVision, ColorClass, ColorConfig, ColorFileError, ColorFileProblem, ConfigError,
    FrameError, Region, RgbFrame,
};
