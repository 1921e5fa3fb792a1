//! An intact MCAP recording read fast: its zstd chunks decompressed on several threads, their
//! records handed out in file order.
//!
//! Reading a recording is bound by decompression: the view images of a noiseless session
//! outweigh its event packets eight to one, and every chunk holds both. `recording::read_recording` decompresses
//! one chunk at a time and copies each record out of it; here worker threads decompress and
//! CRC-check the next chunks while the calling thread walks the records of the one before, in
//! place, so the output order is the file's whatever the threads do. The file must be intact:
//! every check the tolerant reader makes (chunk CRCs before any record of the chunk is used,
//! the data and summary section CRCs, the footer, the closing magic and nothing after it)
//! is made here too, and the first irregularity returns [`Read::Irregular`] for the caller to
//! read the file again with the tolerant reader, which says what is damaged.

use std::collections::VecDeque;
use std::fs::File;
use std::io::{BufReader, Read as _};
use std::path::Path;
use std::sync::Mutex;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};

use mcap::records::op;

/// How the pass ended.
#[derive(Debug, PartialEq, Eq)]
pub enum Read {
    /// Every record was handed out and every check passed.
    Intact,
    /// Something about the file is not as a writer leaves an intact file; what was handed out
    /// is to be discarded.
    Irregular,
}

/// Why the pass stopped early.
#[derive(Debug)]
pub enum Stop<E> {
    Io(std::io::Error),
    /// The visitor's own error.
    Visit(E),
}

/// Largest record accepted, compressed or not, as `recording`'s reader accepts.
const RECORD_LIMIT_BYTES: u64 = 1 << 30;
/// Most worker threads: beyond a few, decompression outruns the one thread walking records.
const MAX_WORKERS: usize = 4;
/// A record's opcode and length.
const HEADER_BYTES: usize = 9;
/// Reads of small records are gathered into reads of this size; a chunk is read past it.
const READ_BUFFER_BYTES: usize = 256 << 10;
/// Buffers larger than this are not kept for the next pass (a recording's chunks are 4 MiB).
const KEEP_BUFFER_BYTES: usize = 64 << 20;

/// The buffers of the last pass, for the next: a read of a 97 s recording decompresses a few
/// chunks at once, and faulting in a fresh 4 MiB buffer for each cost about a sixth of the
/// pass (two-core VM). At most `MAX_WORKERS + 2` pairs of at most [`KEEP_BUFFER_BYTES`].
static SPARE: Mutex<Vec<(Vec<u8>, Vec<u8>)>> = Mutex::new(Vec::new());

/// A chunk to decompress, and the buffer to decompress it into (reused: fresh pages for every
/// 4 MiB chunk cost as much as the decompression).
struct Job {
    chunk: Vec<u8>,
    out: Vec<u8>,
}

/// A chunk's records, decompressed and CRC-checked (`None`: irregular), and its input buffer
/// for reuse.
struct Done {
    records: Option<Vec<u8>>,
    chunk: Vec<u8>,
}

fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?))
}

fn u64_at(b: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(b.get(at..at + 8)?.try_into().ok()?))
}

/// The records of a chunk record's body, decompressed into `out` and checked against the
/// chunk's CRC; `None` for anything irregular.
fn decompress(
    body: &[u8],
    zstd: &mut zstd::bulk::Decompressor<'_>,
    mut out: Vec<u8>,
) -> Option<Vec<u8>> {
    // start time, end time, uncompressed size, CRC, compression, records.
    let size = u64_at(body, 16)?;
    let crc = u32_at(body, 24)?;
    let name_len = u32_at(body, 28)? as usize;
    let name = body.get(32..32 + name_len)?;
    let records_len = u64_at(body, 32 + name_len)?;
    let records = body.get(40 + name_len..)?;
    if records.len() as u64 != records_len || size > RECORD_LIMIT_BYTES {
        return None;
    }
    out.clear();
    match name {
        b"zstd" => {
            out.reserve(size as usize);
            zstd.decompress_to_buffer(records, &mut out).ok()?;
        }
        b"" => out.extend_from_slice(records),
        // lz4 and anything else: the tolerant reader's business.
        _ => return None,
    }
    (out.len() as u64 == size && (crc == 0 || crc32fast::hash(&out) == crc)).then_some(out)
}

fn worker(jobs: Receiver<Job>, done: SyncSender<Done>) {
    let Ok(mut zstd) = zstd::bulk::Decompressor::new() else {
        return;
    };
    for Job { chunk, out } in jobs {
        let records = decompress(&chunk[HEADER_BYTES..], &mut zstd, out);
        if done.send(Done { records, chunk }).is_err() {
            return;
        }
    }
}

/// Hands `visit` every record inside `records` (a chunk's, or a lone record), in order; false
/// when the records do not fill it exactly.
fn walk<E>(records: &[u8], visit: &mut impl FnMut(u8, &[u8]) -> Result<(), E>) -> Result<bool, E> {
    let mut at = 0;
    while at < records.len() {
        let Some(len) = u64_at(records, at + 1) else {
            return Ok(false);
        };
        let end = (at + HEADER_BYTES) as u64 + len;
        if end > records.len() as u64 {
            return Ok(false);
        }
        visit(records[at], &records[at + HEADER_BYTES..end as usize])?;
        at = end as usize;
    }
    Ok(true)
}

/// The file, record by record. Buffered: every chunk is followed by a small message index
/// record per channel.
struct Records {
    file: BufReader<File>,
    left: u64,
}

impl Records {
    /// The next record (opcode, length, body) into `buf`; `None` when the file ends inside it
    /// or its length is past the limit.
    fn next(&mut self, buf: &mut Vec<u8>) -> std::io::Result<Option<()>> {
        let mut header = [0u8; HEADER_BYTES];
        if self.left < HEADER_BYTES as u64 {
            return Ok(None);
        }
        self.file.read_exact(&mut header)?;
        let len = u64::from_le_bytes(header[1..].try_into().unwrap_or_default());
        if len > RECORD_LIMIT_BYTES || len > self.left - HEADER_BYTES as u64 {
            return Ok(None);
        }
        buf.clear();
        buf.extend_from_slice(&header);
        buf.resize(HEADER_BYTES + len as usize, 0);
        self.file.read_exact(&mut buf[HEADER_BYTES..])?;
        self.left -= (HEADER_BYTES + len as usize) as u64;
        Ok(Some(()))
    }
}

/// The workers, each fed through its own lane, and the chunks they hold, oldest first: chunks
/// go round the lanes in turn, so taking them back in the same turn keeps the file's order.
struct Pipeline {
    lanes: Vec<(SyncSender<Job>, Receiver<Done>)>,
    in_flight: VecDeque<usize>,
    next_lane: usize,
    /// Buffers back from the workers: (chunk record, decompressed records).
    spare: Vec<(Vec<u8>, Vec<u8>)>,
}

impl Pipeline {
    /// Hands `chunk` (a whole chunk record) to the next worker and returns a buffer to read
    /// the next record into; `None` when the worker is gone.
    fn send(&mut self, chunk: Vec<u8>) -> Option<Vec<u8>> {
        let (next, out) = self.spare.pop().unwrap_or_default();
        let lane = self.next_lane;
        self.lanes[lane].0.send(Job { chunk, out }).ok()?;
        self.next_lane = (lane + 1) % self.lanes.len();
        self.in_flight.push_back(lane);
        Some(next)
    }

    /// Keeps the buffers back from the workers for the next pass.
    fn keep_spare(&mut self) {
        let small = |(a, b): &(Vec<u8>, Vec<u8>)| {
            a.capacity() <= KEEP_BUFFER_BYTES && b.capacity() <= KEEP_BUFFER_BYTES
        };
        if let Ok(mut kept) = SPARE.lock() {
            kept.extend(self.spare.drain(..).filter(small));
            kept.truncate(MAX_WORKERS + 2);
        }
    }

    /// Hands `visit` the records of the oldest chunk in flight; false when it is irregular.
    fn finish_oldest<E>(
        &mut self,
        visit: &mut impl FnMut(u8, &[u8]) -> Result<(), E>,
    ) -> Result<bool, E> {
        let Some(lane) = self.in_flight.pop_front() else {
            return Ok(true);
        };
        let Ok(Done {
            records: Some(out),
            chunk,
        }) = self.lanes[lane].1.recv()
        else {
            return Ok(false);
        };
        let whole = walk(&out, visit)?;
        self.spare.push((chunk, out));
        Ok(whole)
    }
}

/// The data section's records of the MCAP file at `path`, inside chunks and out, to `visit`
/// in file order, when the file is intact (see the module's text). Workers: one per core but
/// this thread's, at least one, at most `MAX_WORKERS`.
pub fn read_intact<E>(
    path: &Path,
    mut visit: impl FnMut(u8, &[u8]) -> Result<(), E>,
) -> Result<Read, Stop<E>> {
    let mut file = File::open(path).map_err(Stop::Io)?;
    let len = file.metadata().map_err(Stop::Io)?.len();
    let mut magic = [0u8; 8];
    if len < 16 || file.read_exact(&mut magic).is_err() || magic != *mcap::MAGIC {
        return Ok(Read::Irregular);
    }
    let mut records = Records {
        file: BufReader::with_capacity(READ_BUFFER_BYTES, file),
        left: len - 8,
    };
    // This thread walks the records while the workers decompress: one worker per other core
    // kept the two busiest (two cores: 39 ms with one worker, 43 ms with two, for 205 MB of
    // chunks).
    let workers = std::thread::available_parallelism()
        .map_or(1, |n| usize::from(n).saturating_sub(1))
        .clamp(1, MAX_WORKERS);
    std::thread::scope(|scope| {
        let mut pipeline = Pipeline {
            lanes: Vec::with_capacity(workers),
            in_flight: VecDeque::new(),
            next_lane: 0,
            spare: SPARE
                .lock()
                .map(|mut s| std::mem::take(&mut *s))
                .unwrap_or_default(),
        };
        for _ in 0..workers {
            let (job_tx, job_rx) = sync_channel::<Job>(1);
            let (done_tx, done_rx) = sync_channel::<Done>(1);
            scope.spawn(move || worker(job_rx, done_tx));
            pipeline.lanes.push((job_tx, done_rx));
        }
        let mut data_crc = crc32fast::Hasher::new();
        data_crc.update(&magic);
        let mut buf = Vec::new();
        loop {
            if records.next(&mut buf).map_err(Stop::Io)?.is_none() {
                return Ok(Read::Irregular);
            }
            let opcode = buf[0];
            if opcode == op::DATA_END {
                break;
            }
            data_crc.update(&buf);
            let regular = if opcode != op::CHUNK {
                walk(&buf, &mut visit).map_err(Stop::Visit)?
            } else {
                // One chunk more than workers in flight: each has the next to start on while
                // this thread walks the oldest.
                let walked = pipeline.in_flight.len() <= workers
                    || pipeline.finish_oldest(&mut visit).map_err(Stop::Visit)?;
                match pipeline.send(std::mem::take(&mut buf)) {
                    Some(next) => buf = next,
                    None => return Ok(Read::Irregular),
                }
                walked
            };
            if !regular {
                return Ok(Read::Irregular);
            }
        }
        while !pipeline.in_flight.is_empty() {
            if !pipeline.finish_oldest(&mut visit).map_err(Stop::Visit)? {
                return Ok(Read::Irregular);
            }
        }
        pipeline.keep_spare();
        summary_checks(&mut records, &buf, data_crc.finalize()).map_err(Stop::Io)
    })
}

/// The checks after the data section (`data_end`: its `DataEnd` record): the data CRC, the
/// summary records' CRC against the footer's, the closing magic and nothing after it.
fn summary_checks(records: &mut Records, data_end: &[u8], data_crc: u32) -> std::io::Result<Read> {
    let saved = u32_at(data_end, HEADER_BYTES).unwrap_or(0);
    if saved != 0 && saved != data_crc {
        return Ok(Read::Irregular);
    }
    let mut summary_crc = crc32fast::Hasher::new();
    let mut buf = Vec::new();
    loop {
        if records.next(&mut buf)?.is_none() {
            return Ok(Read::Irregular);
        }
        if buf[0] != op::FOOTER {
            summary_crc.update(&buf);
            continue;
        }
        // The summary CRC covers the footer up to its own CRC field.
        let Some(covered) = buf.get(..HEADER_BYTES + 16) else {
            return Ok(Read::Irregular);
        };
        summary_crc.update(covered);
        let saved = u32_at(&buf, HEADER_BYTES + 16).unwrap_or(0);
        if saved != 0 && saved != summary_crc.finalize() {
            return Ok(Read::Irregular);
        }
        let mut end = [0u8; 8];
        let closed =
            records.left == 8 && records.file.read_exact(&mut end).is_ok() && end == *mcap::MAGIC;
        return Ok(if closed {
            Read::Intact
        } else {
            Read::Irregular
        });
    }
}
