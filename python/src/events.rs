//! Event packets between numpy and `proto::EventPacket`: the `EVENT_DTYPE` record layout, the
//! checked conversion both ways, and the `waggle.EventPacket` class that carries one packet
//! (and its wire bytes) in Python.
//!
//! A record is 13 packed little-endian bytes, `t_ns: i64 | x: u16 | y: u16 | polarity: i8`. The
//! read side never copies the caller's array: it reads the records through a `uint8` view of
//! it. Only the packet built from them is new memory, because `EventPacket` owns its
//! struct-of-arrays.

use numpy::{PyArray1, PyArrayDescr, PyArrayDescrMethods, PyUntypedArray, PyUntypedArrayMethods};
use proto::{EventPacket, Polarity};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyBytes;

use crate::errors::{WaggleError, bad_arg, int_arg};

/// Bytes per event record.
pub const RECORD_BYTES: usize = 13;

/// The fields of a record, in order, as numpy spells them.
const FIELDS: [(&str, &str); 4] = [
    ("t_ns", "<i8"),
    ("x", "<u2"),
    ("y", "<u2"),
    ("polarity", "i1"),
];

static EVENT_DTYPE: PyOnceLock<Py<PyArrayDescr>> = PyOnceLock::new();

/// The structured dtype of one event record (`waggle.EVENT_DTYPE`), built once per interpreter.
pub fn event_dtype(py: Python<'_>) -> PyResult<Bound<'_, PyArrayDescr>> {
    let dtype = EVENT_DTYPE.get_or_try_init(py, || {
        let dtype = PyArrayDescr::new(py, FIELDS.to_vec())?;
        if dtype.itemsize() != RECORD_BYTES {
            return Err(WaggleError::new_err(format!(
                "numpy built EVENT_DTYPE with {} bytes per record, not {RECORD_BYTES}",
                dtype.itemsize()
            )));
        }
        Ok::<_, PyErr>(dtype.unbind())
    })?;
    Ok(dtype.bind(py).clone())
}

/// Everything of a packet but its events.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PacketHeader {
    pub seq: u64,
    /// Exclusive.
    pub start_ns: u64,
    /// Inclusive.
    pub end_ns: u64,
    pub width: u16,
    pub height: u16,
    pub valid: bool,
    pub continuous: bool,
}

impl PacketHeader {
    /// The header from Python's integers, each range-checked under its argument name.
    pub fn from_args(
        start_ns: i128,
        end_ns: i128,
        seq: i128,
        valid: bool,
        continuous: bool,
        width: i128,
        height: i128,
    ) -> PyResult<Self> {
        Ok(Self {
            seq: int_arg("seq", seq)?,
            start_ns: int_arg("start_ns", start_ns)?,
            end_ns: int_arg("end_ns", end_ns)?,
            width: int_arg("width", width)?,
            height: int_arg("height", height)?,
            valid,
            continuous,
        })
    }

    fn of(packet: &EventPacket) -> Self {
        Self {
            seq: packet.seq,
            start_ns: packet.start_ns,
            end_ns: packet.end_ns,
            width: packet.width,
            height: packet.height,
            valid: packet.valid,
            continuous: packet.continuous,
        }
    }
}

/// Why records cannot become a packet: the argument (or the event and its field) at fault.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BadRecords {
    /// A header argument (`end_ns`, …) is unusable whatever the events.
    Header { arg: &'static str, reason: String },
    /// Event `index`'s `field` is unusable.
    Event {
        index: usize,
        field: &'static str,
        reason: String,
    },
    /// The buffer is not a whole number of records.
    Length(usize),
}

impl std::fmt::Display for BadRecords {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Header { arg, reason } => write!(f, "{arg}: {reason}"),
            Self::Event {
                index,
                field,
                reason,
            } => write!(f, "events: event {index}, field {field}: {reason}"),
            Self::Length(n) => write!(
                f,
                "events: {n} bytes are not whole {RECORD_BYTES}-byte records"
            ),
        }
    }
}

impl From<BadRecords> for PyErr {
    fn from(e: BadRecords) -> Self {
        WaggleError::new_err(e.to_string())
    }
}

fn le<const N: usize>(bytes: &[u8]) -> [u8; N] {
    std::array::from_fn(|i| bytes[i])
}

/// The packet `header` describes, holding the `EVENT_DTYPE` records in `records`. Every event
/// must lie in `(start_ns, end_ns]`, in time order, on the `width`×`height` sensor, with
/// polarity ±1; the interval must fit the packet's 32-bit offsets.
pub fn packet_from_records(
    header: PacketHeader,
    records: &[u8],
) -> Result<EventPacket, BadRecords> {
    let PacketHeader {
        start_ns, end_ns, ..
    } = header;
    if end_ns < start_ns {
        return Err(BadRecords::Header {
            arg: "end_ns",
            reason: format!("{end_ns} is before start_ns {start_ns}"),
        });
    }
    if end_ns - start_ns > u64::from(u32::MAX) {
        return Err(BadRecords::Header {
            arg: "end_ns",
            reason: format!(
                "the interval ({start_ns}, {end_ns}] is longer than a packet can hold ({} ns)",
                u32::MAX
            ),
        });
    }
    if !records.len().is_multiple_of(RECORD_BYTES) {
        return Err(BadRecords::Length(records.len()));
    }
    let n = records.len() / RECORD_BYTES;
    let mut packet = EventPacket::from_events(
        header.seq,
        (start_ns, end_ns),
        (header.width, header.height),
        &[],
    );
    packet.valid = header.valid;
    packet.continuous = header.continuous;
    packet.xs.reserve_exact(n);
    packet.ys.reserve_exact(n);
    packet.dt_ns.reserve_exact(n);
    let mut polarities = Vec::with_capacity(n);
    let mut last_t = None;
    for (index, r) in records.chunks_exact(RECORD_BYTES).enumerate() {
        let bad = |field, reason| BadRecords::Event {
            index,
            field,
            reason,
        };
        let t = i64::from_le_bytes(le(&r[0..8]));
        let (x, y) = (
            u16::from_le_bytes(le(&r[8..10])),
            u16::from_le_bytes(le(&r[10..12])),
        );
        let dt = u64::try_from(t)
            .ok()
            .filter(|&t| t > start_ns && t <= end_ns)
            .map(|t| t - start_ns)
            .ok_or_else(|| bad("t_ns", format!("{t} is outside ({start_ns}, {end_ns}]")))?;
        if let Some(last) = last_t.filter(|&last| t < last) {
            let reason = format!("{t} is before the previous event's {last} (not in time order)");
            return Err(bad("t_ns", reason));
        }
        last_t = Some(t);
        if x >= header.width {
            return Err(bad("x", format!("{x} is not below width {}", header.width)));
        }
        if y >= header.height {
            return Err(bad(
                "y",
                format!("{y} is not below height {}", header.height),
            ));
        }
        polarities.push(match r[12] as i8 {
            1 => Polarity::On,
            -1 => Polarity::Off,
            p => {
                return Err(bad(
                    "polarity",
                    format!("{p} is neither +1 (ON) nor -1 (OFF)"),
                ));
            }
        });
        packet.xs.push(x);
        packet.ys.push(y);
        // Fits: the interval was checked to fit u32 above.
        packet.dt_ns.push(dt as u32);
    }
    packet.on_bits = EventPacket::pack_polarities(polarities);
    Ok(packet)
}

/// The `EVENT_DTYPE` records of `packet`'s events, in order.
pub fn records_from_packet(packet: &EventPacket) -> Vec<u8> {
    let mut out = Vec::with_capacity(packet.len() * RECORD_BYTES);
    for i in 0..packet.len() {
        // A packet decoded from the wire holds offsets within its interval, so this cannot
        // leave i64 for any stamp below 292 years.
        let t = i64::try_from(packet.t_ns(i)).unwrap_or(i64::MAX);
        out.extend_from_slice(&t.to_le_bytes());
        out.extend_from_slice(&packet.xs[i].to_le_bytes());
        out.extend_from_slice(&packet.ys[i].to_le_bytes());
        out.push(packet.polarity(i).sign() as u8);
    }
    out
}

/// Borrows `events`, a 1-D C-contiguous array of `EVENT_DTYPE`, as its record bytes and hands
/// them to `f` (no copy).
pub fn with_records<R>(
    events: &Bound<'_, PyAny>,
    f: impl FnOnce(&[u8]) -> PyResult<R>,
) -> PyResult<R> {
    let py = events.py();
    let array = events
        .cast::<PyUntypedArray>()
        .map_err(|_| bad_arg("events", "expected a numpy array of waggle.EVENT_DTYPE"))?;
    let dtype = array.dtype();
    if !(dtype.itemsize() == RECORD_BYTES && dtype.is_equiv_to(&event_dtype(py)?)) {
        return Err(bad_arg(
            "events",
            format!(
                "dtype {dtype} is not waggle.EVENT_DTYPE \
                 (packed t_ns <i8, x <u2, y <u2, polarity i1)"
            ),
        ));
    }
    if array.ndim() != 1 {
        return Err(bad_arg(
            "events",
            format!("expected a 1-D array, got {} dimensions", array.ndim()),
        ));
    }
    if !array.is_c_contiguous() {
        return Err(bad_arg(
            "events",
            "the array is not contiguous (pass np.ascontiguousarray(events))",
        ));
    }
    let bytes = array.call_method1("view", (numpy::dtype::<u8>(py),))?;
    let bytes = bytes
        .extract::<numpy::PyReadonlyArray1<'_, u8>>()
        .map_err(|e| bad_arg("events", format!("cannot read its bytes: {e}")))?;
    let slice = bytes
        .as_slice()
        .map_err(|e| bad_arg("events", format!("cannot read its bytes: {e}")))?;
    f(slice)
}

/// The packet holding `events` (see [`packet_from_records`]).
pub fn packet_from_array(events: &Bound<'_, PyAny>, header: PacketHeader) -> PyResult<EventPacket> {
    with_records(events, |records| Ok(packet_from_records(header, records)?))
}

/// A new array of `EVENT_DTYPE` holding `packet`'s events.
pub fn array_from_packet<'py>(
    py: Python<'py>,
    packet: &EventPacket,
) -> PyResult<Bound<'py, PyAny>> {
    let bytes = PyArray1::from_vec(py, records_from_packet(packet));
    bytes.call_method1("view", (event_dtype(py)?,))
}

/// One packet of events from one camera, as Waggle's receivers and its wire carry it.
///
/// `EventPacket(events, start_ns, end_ns, seq, valid=True, continuous=True, width=640,
/// height=480)`: the packet `seq` covering `(start_ns, end_ns]` of a `width`×`height` sensor,
/// holding `events` (an array of `EVENT_DTYPE`, in time order). Raises `WaggleError` naming the
/// first bad argument, or the first bad event and its field.
#[pyclass(frozen, eq, module = "waggle", name = "EventPacket")]
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PyEventPacket {
    pub packet: EventPacket,
}

#[pymethods]
impl PyEventPacket {
    #[new]
    #[pyo3(signature = (
        events, start_ns, end_ns, seq, valid = true, continuous = true, width = 640, height = 480
    ))]
    #[expect(clippy::too_many_arguments, reason = "one per Python keyword argument")]
    fn new(
        events: &Bound<'_, PyAny>,
        start_ns: i128,
        end_ns: i128,
        seq: i128,
        valid: bool,
        continuous: bool,
        width: i128,
        height: i128,
    ) -> PyResult<Self> {
        let header =
            PacketHeader::from_args(start_ns, end_ns, seq, valid, continuous, width, height)?;
        Ok(Self {
            packet: packet_from_array(events, header)?,
        })
    }

    /// The packet a `proto::encode`d wire message holds (what an observer receives).
    #[staticmethod]
    fn from_bytes(data: &[u8]) -> PyResult<Self> {
        proto::decode::<EventPacket>(data)
            .map(|packet| Self { packet })
            .map_err(|e| bad_arg("data", e))
    }

    /// The packet as a wire message (`proto::encode`).
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &proto::encode(&self.packet))
    }

    /// A new array of `EVENT_DTYPE` holding the packet's events.
    fn events<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        array_from_packet(py, &self.packet)
    }

    /// Packet sequence number, contiguous from 0 for one camera.
    #[getter]
    fn seq(&self) -> u64 {
        self.packet.seq
    }

    /// Start of the interval (exclusive), ns.
    #[getter]
    fn start_ns(&self) -> u64 {
        self.packet.start_ns
    }

    /// End of the interval (inclusive), ns; the packet's stamp.
    #[getter]
    fn end_ns(&self) -> u64 {
        self.packet.end_ns
    }

    /// Sensor width, pixels.
    #[getter]
    fn width(&self) -> u16 {
        self.packet.width
    }

    /// Sensor height, pixels.
    #[getter]
    fn height(&self) -> u16 {
        self.packet.height
    }

    /// False when the sensor could not produce trustworthy data for this interval.
    #[getter]
    fn valid(&self) -> bool {
        self.packet.valid
    }

    /// False when this packet does not directly follow the previous one.
    #[getter]
    fn continuous(&self) -> bool {
        self.packet.continuous
    }

    /// The number of events.
    fn __len__(&self) -> usize {
        self.packet.len()
    }

    fn __repr__(&self) -> String {
        let PacketHeader {
            seq,
            start_ns,
            end_ns,
            width,
            height,
            valid,
            continuous,
        } = PacketHeader::of(&self.packet);
        format!(
            "EventPacket(seq={seq}, start_ns={start_ns}, end_ns={end_ns}, {} events, \
             {width}x{height}, valid={}, continuous={})",
            self.packet.len(),
            py_bool(valid),
            py_bool(continuous)
        )
    }
}

fn py_bool(b: bool) -> &'static str {
    if b { "True" } else { "False" }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("EVENT_DTYPE", event_dtype(m.py())?)?;
    m.add_class::<PyEventPacket>()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> PacketHeader {
        PacketHeader {
            seq: 3,
            start_ns: 1_000,
            end_ns: 41_000,
            width: 640,
            height: 480,
            valid: true,
            continuous: false,
        }
    }

    fn record(t: i64, x: u16, y: u16, p: i8) -> Vec<u8> {
        let mut r = t.to_le_bytes().to_vec();
        r.extend_from_slice(&x.to_le_bytes());
        r.extend_from_slice(&y.to_le_bytes());
        r.push(p as u8);
        r
    }

    #[test]
    fn records_round_trip_through_a_packet() {
        let records = [
            record(1_001, 0, 0, 1),
            record(20_000, 639, 479, -1),
            record(20_000, 5, 6, -1),
            record(41_000, 320, 240, 1),
        ]
        .concat();
        let packet = packet_from_records(header(), &records).expect("valid records");
        assert_eq!(packet.len(), 4);
        assert_eq!(packet.dt_ns, vec![1, 19_000, 19_000, 40_000]);
        assert_eq!(packet.polarity(1), Polarity::Off);
        assert!(!packet.continuous);
        assert_eq!(proto::Validate::validate(&packet), Ok(()));
        assert_eq!(records_from_packet(&packet), records);
    }

    #[test]
    fn the_first_bad_event_and_field_are_named() {
        let cases = [
            (record(1_000, 0, 0, 1), "t_ns"),
            (record(41_001, 0, 0, 1), "t_ns"),
            (record(-5, 0, 0, 1), "t_ns"),
            (record(2_000, 640, 0, 1), "x"),
            (record(2_000, 0, 480, 1), "y"),
            (record(2_000, 0, 0, 0), "polarity"),
        ];
        for (bad, field) in cases {
            let records = [record(1_500, 1, 1, 1), bad].concat();
            match packet_from_records(header(), &records) {
                Err(BadRecords::Event {
                    index: 1, field: f, ..
                }) => assert_eq!(f, field),
                other => panic!("{field}: {other:?}"),
            }
        }
        let unordered = [record(3_000, 1, 1, 1), record(2_000, 1, 1, 1)].concat();
        assert!(matches!(
            packet_from_records(header(), &unordered),
            Err(BadRecords::Event {
                index: 1,
                field: "t_ns",
                ..
            })
        ));
    }

    #[test]
    fn an_unusable_interval_names_end_ns() {
        let reversed = PacketHeader {
            end_ns: 999,
            ..header()
        };
        let too_long = PacketHeader {
            end_ns: 1_000 + u64::from(u32::MAX) + 1,
            ..header()
        };
        for h in [reversed, too_long] {
            assert!(matches!(
                packet_from_records(h, &[]),
                Err(BadRecords::Header { arg: "end_ns", .. })
            ));
        }
        assert_eq!(
            packet_from_records(header(), &[0; 14]),
            Err(BadRecords::Length(14))
        );
    }
}
