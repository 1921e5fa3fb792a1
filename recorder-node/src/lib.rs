//! Recorder: session recording into MCAP.
