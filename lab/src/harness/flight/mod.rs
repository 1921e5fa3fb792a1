//! What every harness flies: the performer's broadcast schedule as physics references
//! ([`performer`]), the real air of a perturbed trial ([`air`]), a flight rendered once and
//! kept ([`rendered`]) and its on-disk cache shared by one host's processes ([`cache`]), and
//! the event cameras' output as EVT 3.0 files ([`raw`]).

pub mod air;
pub mod cache;
pub mod performer;
pub mod raw;
pub mod rendered;
