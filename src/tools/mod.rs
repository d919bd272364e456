//! What measures realcam rather than renders with it: the benchmark (`realcam bench`), the
//! accuracy report (`realcam accuracy`), image error metrics (`realcam compare`) and the
//! synthetic test scenes (`realcam synth`); the entry points of the fuzzing harness.

pub mod accuracy;
pub mod accuracy_flare;
pub mod bench;
pub mod bench_flare;
pub mod bench_motion;
pub mod bench_sequence;
pub mod bezier_ghosts;
pub mod error_budget;
pub mod flare_fit;
pub mod flare_predict;
pub mod fuzz;
pub mod highlight_discs;
pub mod layered_scene;
pub mod metrics;
pub mod synth;
pub mod warm_up;
