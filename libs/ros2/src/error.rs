//! What can go wrong writing a bag or exporting a recording; every error names its file, and a
//! damaged recording the byte range that could not be read.

/// Why a bag could not be written or a recording exported.
#[derive(Debug, thiserror::Error)]
pub enum Ros2Error {
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("writing the MCAP file {path}: {source}")]
    Mcap {
        path: String,
        #[source]
        source: mcap::McapError,
    },
    #[error("no message definition for {name}")]
    UnknownType { name: String },
    #[error("topic {topic} was not declared in the bag")]
    UnknownTopic { topic: String },
    #[error("{path} exists and is not an empty directory: choose another --out")]
    OutputExists { path: String },
    #[error(transparent)]
    Recording(#[from] recording::ReadError),
    #[error("the recording {path} is damaged at bytes {from_byte}..{to_byte}: {reason}")]
    Damaged {
        path: String,
        from_byte: u64,
        to_byte: u64,
        reason: String,
    },
    #[error("the recording {path} is incomplete: {reason}")]
    Incomplete { path: String, reason: String },
    #[error(
        "the recording {path} keeps the event cameras' input, not their packets (`waggle run \
         --record-events input`, the default with a sensor noise model), and nothing \
         regenerates them here: the bag would hold no events"
    )]
    EventsNotRecorded { path: String },
    #[error("the recording {path}: {reason}")]
    Substitute { path: String, reason: String },
    #[error(
        "the recording {path}: message {index} (topic {topic}, log time {log_time_ns} ns) does \
         not decode: {reason}"
    )]
    Undecodable {
        path: String,
        index: u64,
        topic: String,
        log_time_ns: u64,
        reason: String,
    },
    #[error("the recording {path}: {observer}'s RGB update {seq} cannot be applied: {reason}")]
    Unassembled {
        path: String,
        observer: String,
        seq: u64,
        reason: String,
    },
    #[error("sim time {time_ns} ns does not fit builtin_interfaces/Time (int32 seconds)")]
    TimeOutOfRange { time_ns: u64 },
    #[error("encoding {observer}'s events as EVT 3.0: {source}")]
    Evt3 {
        observer: String,
        #[source]
        source: event_formats::evt3::Evt3Error,
    },
    #[error("reading the bag {path}: {reason}")]
    BagRead { path: String, reason: String },
    #[error("encoding a PNG image of {observer}: {reason}")]
    Png { observer: String, reason: String },
    #[error("the live ROS 2 view: {reason}")]
    Live { reason: String },
}
