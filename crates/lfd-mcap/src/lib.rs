//! Fast, damage-tolerant reader of lfd MCAP recordings.
//!
//! [`read_recording`] is the Rust twin of `lfd.io.mcapfile.scan` plus the typed decoding of
//! `lfd.io.reader._Loader`: one sequential pass over a possibly damaged file (its own record
//! parsers, [`records`], every length checked against the bytes left before anything is
//! allocated; chunks inflated only after their declared size is checked against the
//! inflation budget), CRC-checked, keeping every message of every intact chunk. A chunk that
//! fails its CRC is lost alone; a damaged record frame (a bad length, an unknown opcode) is
//! stepped over to the next record a writer plausibly made; both are listed in
//! [`Recording::damage`], named from the summary's indexes when the file has them. Hand
//! keypoints, keypoint confidences and object poses are decoded into flat arrays; every other
//! topic is returned as raw `(log_time, payload)` pairs, in file order (only those of
//! [`Options::raw_topics`] when given; every topic is counted either way). Chunks are queued in
//! batches (in file order, each admitted by the bomb check as it is met); a batch is inflated
//! and decoded by the rayon workers in the background (a chunk whose channels are all known
//! is decoded whole there) while the batch before is applied in file order and the next one
//! read, so the result is exactly that of a sequential pass.
//!
//! [`read_summary`] reads only the summary section of a finished recording (and the message
//! indexes and chunks it points to), believing it only as far as it can be checked, and
//! CRC-checks every chunk without keeping it, for a quick look without a full pass.

mod inflate;
pub mod proto;
pub mod records;
mod scan;
mod summary;
mod walk;

pub use scan::{read_recording, read_recording_bytes};
pub use summary::{read_summary, read_summary_bytes};

use std::fmt::Write as _;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

/// The MCAP magic bytes that open (and close) every file.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

/// How many times its file size a recording may inflate to, all chunks together (as
/// `lfd.io.mcapfile.MAX_INFLATION`).
pub const MAX_INFLATION: u64 = 200;

/// A small file may always inflate to this much (8 MiB), whatever its size.
pub const MIN_INFLATE_BYTES: u64 = 8 * (1 << 20);

/// No single chunk may inflate to more than 1 GiB.
pub const MAX_CHUNK_BYTES: u64 = 1 << 30;

/// Bytes of raw payloads [`read_summary`] keeps of the topics asked for (64 MiB: thousands of
/// times what a recording's label channels hold).
pub const SUMMARY_RAW_LIMIT: u64 = 64 << 20;

/// The image topics whose payloads [`Options::images`]` = false` drops.
pub const IMAGE_TOPICS: [&str; 4] = [
    "/camera/color/image_raw",
    "/camera/depth/image_raw",
    "/camera/color/image_raw/compressed",
    "/camera/depth/image_raw/compressed",
];

/// Bytes that all chunks of a file of `file_size` bytes may inflate to, together.
pub fn inflate_limit(file_size: u64) -> u64 {
    MIN_INFLATE_BYTES.max(MAX_INFLATION.saturating_mul(file_size))
}

/// A recording that cannot be read at all (the text is the one `scan()` raises as
/// `RecordingFormatError`). Damage after the magic is not an error: it ends the pass with
/// [`Recording::complete`]` = false`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct ReadError(pub String);

/// What to read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Options {
    /// Keep the payloads of the image topics ([`IMAGE_TOPICS`]); they are counted either way.
    pub images: bool,
    /// Keep the raw payloads of these topics only (`None`: of every topic). The topics not
    /// kept are still counted, with their times, in [`Recording::channels`]; the decoded
    /// tracks are kept either way.
    pub raw_topics: Option<Vec<String>>,
    /// Keep at most this many bytes of raw payloads, all topics together (`None`: no limit);
    /// the messages beyond are counted, their payloads dropped, and
    /// [`Recording::raw_truncated`] says so.
    pub raw_limit: Option<u64>,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            images: true,
            raw_topics: None,
            raw_limit: None,
        }
    }
}

impl Options {
    /// Every topic, the image payloads kept or not.
    pub fn images(images: bool) -> Self {
        Self {
            images,
            raw_topics: None,
            raw_limit: None,
        }
    }

    /// Whether the raw payloads of `topic` are kept.
    pub fn keeps(&self, topic: &str) -> bool {
        (self.images || !IMAGE_TOPICS.contains(&topic))
            && self
                .raw_topics
                .as_ref()
                .is_none_or(|keep| keep.iter().any(|t| t == topic))
    }
}

/// One topic: its first channel's schema and encoding, and its messages' count and time span.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ChannelSummary {
    pub topic: String,
    /// Schema name ("" without a schema).
    pub schema: String,
    pub schema_encoding: String,
    pub schema_data: Vec<u8>,
    /// Message encoding (`protobuf`, `json`, `cdr`, ...).
    pub encoding: String,
    pub metadata: Vec<(String, String)>,
    pub count: u64,
    /// Smallest and largest log time (ns), `None` without messages.
    pub first_ns: Option<i64>,
    pub last_ns: Option<i64>,
}

impl ChannelSummary {
    fn add(&mut self, t: i64) {
        self.count += 1;
        self.first_ns = Some(self.first_ns.map_or(t, |f| f.min(t)));
        self.last_ns = Some(self.last_ns.map_or(t, |l| l.max(t)));
    }
}

/// Metadata records merged by name (a later record's keys update an earlier one's), in order
/// of first appearance.
pub type MetadataMap = Vec<(String, Vec<(String, String)>)>;

/// Raw messages in file order: message `i` has log time `t_ns[i]` and payload
/// `data[offsets[i]..offsets[i + 1]]` (one buffer, not one allocation per message).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawMessages {
    pub t_ns: Vec<i64>,
    pub offsets: Vec<usize>,
    pub data: Vec<u8>,
}

impl Default for RawMessages {
    fn default() -> Self {
        Self {
            t_ns: Vec::new(),
            offsets: vec![0],
            data: Vec::new(),
        }
    }
}

impl RawMessages {
    /// Append a message.
    pub fn push(&mut self, t_ns: i64, payload: &[u8]) {
        self.t_ns.push(t_ns);
        self.data.extend_from_slice(payload);
        self.offsets.push(self.data.len());
    }

    /// Append the messages of `more`.
    pub fn append(&mut self, more: &RawMessages) {
        let base = self.data.len();
        self.t_ns.extend_from_slice(&more.t_ns);
        self.data.extend_from_slice(&more.data);
        self.offsets
            .extend(more.offsets[1..].iter().map(|&o| o + base));
    }

    pub fn len(&self) -> usize {
        self.t_ns.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t_ns.is_empty()
    }

    /// Message `i`: `(log time, payload)`.
    pub fn get(&self, i: usize) -> (i64, &[u8]) {
        (
            self.t_ns[i],
            &self.data[self.offsets[i]..self.offsets[i + 1]],
        )
    }

    /// The messages in order.
    pub fn iter(&self) -> impl Iterator<Item = (i64, &[u8])> + '_ {
        (0..self.len()).map(|i| self.get(i))
    }
}

/// The hand keypoints of one `/hand/<side>/keypoints` topic, in file order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HandTrack {
    pub t_ns: Vec<i64>,
    /// `n * 21 * 3` positions; a message without 21 poses (or not decodable) leaves NaN.
    pub keypoints: Vec<f64>,
    /// The error `lfd.io.reader` raises for this topic (the first, in its sorted and
    /// de-duplicated order, undecodable message, else the first without 21 poses).
    pub bad: Option<String>,
}

/// The per-keypoint confidences of one `/hand/<side>/confidence` topic, in file order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ConfidenceTrack {
    pub t_ns: Vec<i64>,
    /// `m * 21` values in [0, 1] (NaN for an invalid message).
    pub confidence: Vec<f64>,
    /// `m * 21` visibilities (false when absent).
    pub visible: Vec<bool>,
    /// Whether message `i` had a `visible` list.
    pub has_visible: Vec<bool>,
    /// The first (file order) invalid message, as `lfd.io.reader._confidence` words it.
    pub bad: Option<String>,
}

/// The poses of one `/objects/<name>/pose` topic, in file order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PoseTrack {
    pub t_ns: Vec<i64>,
    /// `n * 3` positions.
    pub position: Vec<f64>,
    /// `n * 4` quaternions `x, y, z, w`.
    pub quaternion: Vec<f64>,
    /// The first (sorted, de-duplicated order) undecodable message.
    pub bad: Option<String>,
}

/// A damaged region of a file that [`read_recording`] stepped over: everything else is read.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Damage {
    /// Where the damage starts (a record's offset) and where reading resumed.
    pub offset: u64,
    pub end: u64,
    /// The chunks lost, by ordinal (1-based, file order), when known: from the summary's
    /// chunk indexes, else for a chunk whose record is whole (its contents damaged) when no
    /// region of unknown content came before it.
    pub chunks: Option<Vec<u64>>,
    /// Messages lost, when known (from the message indexes of the chunks lost).
    pub messages: Option<u64>,
    /// What is wrong, one plain line.
    pub why: String,
}

/// Everything [`read_recording`] recovers from a file.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Recording {
    pub library: String,
    pub file_size: u64,
    /// Whether the data section ended with its data-end record.
    pub complete: bool,
    /// Why the pass ended early (`None` when complete).
    pub error: Option<String>,
    /// Damaged regions stepped over (every chunk outside them is read), in file order.
    pub damage: Vec<Damage>,
    /// Chunks in the file: those the summary indexes when damage was met and the file has a
    /// usable summary, else the chunk records read (whole records, damaged contents included).
    pub chunks: u64,
    /// By topic, in order of first appearance.
    pub channels: Vec<ChannelSummary>,
    pub metadata: MetadataMap,
    pub hands: Vec<(String, HandTrack)>,
    pub confidence: Vec<(String, ConfidenceTrack)>,
    pub poses: Vec<(String, PoseTrack)>,
    /// Whether raw payloads were dropped beyond [`Options::raw_limit`].
    pub raw_truncated: bool,
    /// Every other topic (the image topics left out with `images = false`, and any topic not in
    /// [`Options::raw_topics`]).
    pub raw: Vec<(String, RawMessages)>,
}

impl Recording {
    /// Messages recovered, all topics.
    pub fn message_count(&self) -> u64 {
        self.channels.iter().map(|c| c.count).sum()
    }
}

/// One attachment listed in the summary.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AttachmentInfo {
    pub name: String,
    pub media_type: String,
    pub log_time: u64,
    pub size: u64,
}

/// What [`read_summary`] reads from a finished recording's summary section.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Summary {
    pub library: String,
    pub file_size: u64,
    pub channels: Vec<ChannelSummary>,
    pub metadata: MetadataMap,
    pub attachments: Vec<AttachmentInfo>,
    /// Messages in the file that can be read (a damaged chunk's are not), all channels (and
    /// so the channels' counts).
    pub messages: u64,
    /// Chunks in the file (distinct chunk indexes).
    pub chunks: u64,
    /// The chunks that fail to inflate or their CRC (each with its ordinal and messages).
    pub damage: Vec<Damage>,
    /// Whether the requested topics hold more than [`SUMMARY_RAW_LIMIT`] bytes: reading them
    /// stopped there.
    pub raw_truncated: bool,
    /// The raw messages of the requested topics, in file order.
    pub raw: Vec<(String, RawMessages)>,
}

/// Open `path`, check its magic (errors worded as `scan()`), and return the file (at offset 0)
/// and its size.
fn open_checked(path: &Path) -> Result<(File, u64), ReadError> {
    let p = path.display();
    let cannot = |err: std::io::Error| {
        ReadError(format!(
            "cannot open recording {p}: {}",
            py_os_error(&err, &p.to_string())
        ))
    };
    let size = std::fs::metadata(path).map_err(cannot)?.len();
    let mut file = File::open(path).map_err(cannot)?;
    let mut head = Vec::with_capacity(MAGIC.len());
    (&mut file)
        .take(MAGIC.len() as u64)
        .read_to_end(&mut head)
        .map_err(cannot)?;
    check_magic(&head, size, &p.to_string())?;
    file.seek(SeekFrom::Start(0)).map_err(cannot)?;
    Ok((file, size))
}

/// Check the first bytes of a file (`head`, at most the magic's length; `size` bytes in all).
fn check_magic(head: &[u8], size: u64, p: &str) -> Result<(), ReadError> {
    let head = &head[..head.len().min(MAGIC.len())];
    if head.is_empty() {
        return Err(ReadError(format!("{p} is empty, not an MCAP recording")));
    }
    if head[..] != MAGIC[..head.len()] {
        return Err(ReadError(format!(
            "{p} is not an MCAP file (bad magic bytes {})",
            py_bytes_repr(head)
        )));
    }
    if head.len() < MAGIC.len() {
        return Err(ReadError(format!(
            "{p} is cut inside the MCAP magic ({size} bytes)"
        )));
    }
    Ok(())
}

/// An I/O error as Python's `OSError` prints it: `[Errno 2] No such file or directory: 'x'`.
fn py_os_error(err: &std::io::Error, path: &str) -> String {
    match err.raw_os_error() {
        Some(code) => {
            let text = err.to_string();
            let suffix = format!(" (os error {code})");
            let text = text.strip_suffix(&suffix).unwrap_or(&text);
            format!("[Errno {code}] {text}: {}", py_str_repr(path))
        }
        None => err.to_string(),
    }
}

/// `repr(bytes)` as Python writes it (`b'...'`).
pub(crate) fn py_bytes_repr(bytes: &[u8]) -> String {
    let quote = if bytes.contains(&b'\'') && !bytes.contains(&b'"') {
        '"'
    } else {
        '\''
    };
    let mut s = String::from("b");
    s.push(quote);
    for &b in bytes {
        match b {
            b'\\' => s.push_str("\\\\"),
            b'\t' => s.push_str("\\t"),
            b'\n' => s.push_str("\\n"),
            b'\r' => s.push_str("\\r"),
            b'\'' if quote == '\'' => s.push_str("\\'"),
            0x20..=0x7e => s.push(b as char),
            _ => {
                let _ = write!(s, "\\x{b:02x}");
            }
        }
    }
    s.push(quote);
    s
}

/// `repr(str)` as Python writes it, for the usual (printable) strings.
pub(crate) fn py_str_repr(text: &str) -> String {
    let quote = if text.contains('\'') && !text.contains('"') {
        '"'
    } else {
        '\''
    };
    let mut s = String::new();
    s.push(quote);
    for c in text.chars() {
        match c {
            '\\' => s.push_str("\\\\"),
            '\t' => s.push_str("\\t"),
            '\n' => s.push_str("\\n"),
            '\r' => s.push_str("\\r"),
            '\'' if quote == '\'' => s.push_str("\\'"),
            c if (c as u32) < 0x20 || c as u32 == 0x7f => {
                let _ = write!(s, "\\x{:02x}", c as u32);
            }
            c => s.push(c),
        }
    }
    s.push(quote);
    s
}
