//! slod composed: the adaptive cloth and the animation crowd for Rust users, and the C ABI over them.
#![warn(missing_docs)]
