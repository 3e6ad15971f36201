//! Shared helpers for slod's cross-crate scenario tests (the tests themselves live in `tests/tests`).
#![forbid(unsafe_code)]

pub mod native;
