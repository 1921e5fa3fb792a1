//! Event-camera file formats, so that real cameras' recordings and Waggle's synthetic events
//! meet: [`evt3`], Prophesee's EVT 3.0 (`.raw`), written and read.
//!
//! Pure code over byte slices and `Write`rs: no file system, no clock.

pub mod evt3;
