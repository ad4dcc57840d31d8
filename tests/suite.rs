//! The end-to-end tests of `bgc`, in one test binary: each file below was a binary of its
//! own, and nine binaries linking the same compiler took longer to build than the tests took
//! to run; in one binary the slow tests also share the cores with the quick ones.
//!
//! Run one part with `cargo test -p bgc --test suite models::` (the file's name).

#[path = "common/mod.rs"]
mod common;

#[path = "bad_models.rs"]
mod bad_models;
#[path = "c_backend.rs"]
mod c_backend;
#[path = "cli.rs"]
mod cli;
#[path = "end_to_end.rs"]
mod end_to_end;
#[path = "fuzz.rs"]
mod fuzz;
#[path = "identify.rs"]
mod identify;
#[path = "isolability.rs"]
mod isolability;
#[path = "models.rs"]
mod models;
#[path = "mutations.rs"]
mod mutations;
#[path = "no_std.rs"]
mod no_std;
#[path = "pump.rs"]
mod pump;
#[path = "refusals.rs"]
mod refusals;
#[path = "residuals.rs"]
mod residuals;
