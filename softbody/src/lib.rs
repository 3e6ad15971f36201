//! A deterministic mass-spring (XPBD) cloth and the TreeCut-SoftBody operations on it.
#![forbid(unsafe_code)]
#![warn(missing_docs)]
