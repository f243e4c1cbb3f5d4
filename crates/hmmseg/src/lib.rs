//! `hmmseg`: the numerical engine of lfd.
//!
//! Pure Rust on nalgebra, no Python: continuous HMMs (Gaussian and Gaussian-mixture emissions,
//! Baum-Welch training, forward / prefix / Viterbi scoring), dynamic time warping, [0, 1]
//! normalisation, the signal processing and rotations of the preprocessing
//! (Butterworth design, `filtfilt`, cubic splines, quaternions and slerp), the eight features of Table I, stage-1 over-segmentation and the stage-2
//! skill cut (greedy loop of Eq. 3-5 and a segmental DP).

pub mod dtw;
pub mod error;
pub mod features;
pub mod hmm;
pub mod limits;
pub mod normalize;
pub mod options;
pub mod rotation;
pub mod signal;

pub use error::{EngineError, Result};
pub use options::OptionEnum;
pub mod segment;
pub mod stage1;
