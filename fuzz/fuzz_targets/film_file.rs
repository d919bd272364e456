//! realcam::tools::fuzz::film_file under libFuzzer: a broken promise (NaN or Inf in a successful
//! result) panics; so does a panic of realcam, and an abort or an allocation beyond libFuzzer's
//! -rss_limit_mb ends the run with the input saved.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(violation) = realcam::tools::fuzz::film_file(data) {
        panic!("{violation}");
    }
});
