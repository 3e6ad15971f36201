//! BSWDF salience: turns motion, lighting and the camera into a priority per node.
#![forbid(unsafe_code)]
#![warn(missing_docs)]
