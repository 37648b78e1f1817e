//! Perception: colour segmentation (CMVision) and what is built on it.
