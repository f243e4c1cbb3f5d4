//! [`read_recording`]: one sequential, damage-tolerant pass with typed decoding.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;
use std::sync::mpsc::{Receiver, TryRecvError};
use std::sync::Arc;

use prost::Message as _;
use serde_json::Value;

use crate::inflate::{inflate, Budget};
use crate::proto::{PoseInFrame, PosesInFrame};
use crate::records::{self, op, ChunkHeader};
use crate::walk::{Next, Source, Walker};
use crate::{
    open_checked, ChannelSummary, ConfidenceTrack, Damage, HandTrack, MetadataMap, Options,
    PoseTrack, RawMessages, ReadError, Recording,
};
use rayon::prelude::*;

/// Keypoints per hand.
const KP: usize = 21;

/// Why the pass stopped early, or a record that does not parse.
pub(crate) enum Stop {
    Fatal(ReadError),
    /// The pass ends here (the file is cut).
    Damaged(String),
    /// This record is damaged: resynchronise after it.
    Record(String),
}

pub(crate) use records::{message as parse_message, split as split_records};

/// A log time as lfd reads it (an error beyond `i64::MAX`, the text of `scan()`).
pub(crate) fn log_time(path: &str, topic: &str, t: u64) -> Result<i64, ReadError> {
    i64::try_from(t).map_err(|_| {
        ReadError(format!(
            "{path}: a message on {topic} has log_time {t} ns, beyond the largest time lfd \
             reads (2**63 - 1 ns)"
        ))
    })
}

/// Merge a metadata record into `map` (by name; later keys update).
pub(crate) fn merge_metadata(
    map: &mut MetadataMap,
    name: String,
    values: impl IntoIterator<Item = (String, String)>,
) {
    let at = if let Some(i) = map.iter().position(|(n, _)| *n == name) {
        i
    } else {
        map.push((name, Vec::new()));
        map.len() - 1
    };
    let entry = &mut map[at].1;
    for (k, v) in values {
        if let Some(slot) = entry.iter_mut().find(|(ek, _)| *ek == k) {
            slot.1 = v;
        } else {
            entry.push((k, v));
        }
    }
}

/// A message held back because it is undecodable (`decode`) or has not 21 poses.
struct Bad {
    index: usize,
    t: i64,
    decode: bool,
    text: String,
}

/// The `bad` text `lfd.io.reader` raises: it walks the messages sorted by time, the first of
/// equal times kept, raising at the first undecodable one, else (once all are decoded) at
/// the first without 21 poses.
fn pick_bad(times: &[i64], bad: Vec<Bad>) -> Option<String> {
    if bad.is_empty() {
        return None;
    }
    let mut first: HashMap<i64, usize> = HashMap::with_capacity(times.len());
    for (i, &t) in times.iter().enumerate() {
        first.entry(t).or_insert(i);
    }
    let kept = bad
        .into_iter()
        .filter(|b| first.get(&b.t) == Some(&b.index));
    let (decode, count): (Vec<Bad>, Vec<Bad>) = kept.partition(|b| b.decode);
    let earliest = |v: Vec<Bad>| v.into_iter().min_by_key(|b| b.t).map(|b| b.text);
    earliest(decode).or_else(|| earliest(count))
}

enum Kind {
    Hand(HandTrack, Vec<Bad>),
    Confidence(ConfidenceTrack),
    Pose(PoseTrack, Vec<Bad>),
    Raw(RawMessages),
    /// A raw topic not kept (an image topic with `images = false`, a topic not in
    /// `raw_topics`): counted, payloads dropped.
    Dropped,
}

impl Kind {
    /// An empty track of the same kind.
    fn empty(&self) -> Kind {
        match self {
            Kind::Hand(..) => Kind::Hand(HandTrack::default(), Vec::new()),
            Kind::Confidence(_) => Kind::Confidence(ConfidenceTrack::default()),
            Kind::Pose(..) => Kind::Pose(PoseTrack::default(), Vec::new()),
            Kind::Raw(_) => Kind::Raw(RawMessages::default()),
            Kind::Dropped => Kind::Dropped,
        }
    }

    /// Append the messages of `more` (decoded after these, of the same kind).
    fn append(&mut self, more: Kind) {
        match (self, more) {
            (Kind::Hand(track, bad), Kind::Hand(m, more_bad)) => {
                let offset = track.t_ns.len();
                track.t_ns.extend_from_slice(&m.t_ns);
                track.keypoints.extend_from_slice(&m.keypoints);
                bad.extend(more_bad.into_iter().map(|b| Bad {
                    index: b.index + offset,
                    ..b
                }));
            }
            (Kind::Pose(track, bad), Kind::Pose(m, more_bad)) => {
                let offset = track.t_ns.len();
                track.t_ns.extend_from_slice(&m.t_ns);
                track.position.extend_from_slice(&m.position);
                track.quaternion.extend_from_slice(&m.quaternion);
                bad.extend(more_bad.into_iter().map(|b| Bad {
                    index: b.index + offset,
                    ..b
                }));
            }
            (Kind::Confidence(track), Kind::Confidence(m)) => {
                track.t_ns.extend_from_slice(&m.t_ns);
                track.confidence.extend_from_slice(&m.confidence);
                track.visible.extend_from_slice(&m.visible);
                track.has_visible.extend_from_slice(&m.has_visible);
                if track.bad.is_none() {
                    track.bad = m.bad;
                }
            }
            (Kind::Raw(raw), Kind::Raw(m)) => raw.append(&m),
            _ => {}
        }
    }
}

struct Topic {
    summary: ChannelSummary,
    kind: Kind,
}

fn is_object_topic(topic: &str) -> bool {
    let (prefix, suffix) = ("/objects/", "/pose");
    topic.len() > prefix.len() + suffix.len()
        && topic.starts_with(prefix)
        && topic.ends_with(suffix)
}

struct Schema {
    name: String,
    encoding: String,
    data: Vec<u8>,
}

struct State {
    path: String,
    options: Options,
    budget: Budget,
    library: String,
    schemas: HashMap<u16, Schema>,
    /// Channel id -> index into `topics` (`usize::MAX`: unknown).
    channels: Vec<usize>,
    scratch: Scratch,
    topics: Vec<Topic>,
    by_topic: HashMap<String, usize>,
    metadata: MetadataMap,
    data_done: bool,
    /// A topic lfd decodes that carries two message types (the first found; the file is
    /// refused with it).
    conflict: Option<String>,
    /// Chunks admitted but not yet read (decoded together, in parallel).
    pending: Vec<Pending>,
    /// Their declared uncompressed bytes.
    pending_bytes: u64,
    /// Batches queued so far (the first ones are small: their chunks define the channels).
    batches: u32,
    /// The last batch queued, being decoded by the workers (not yet applied).
    inflight: Option<Receiver<Vec<Chunked>>>,
    /// The channel map and the topics (name, empty track) the workers decode with; `None`
    /// after a change.
    snapshot: Option<Snapshot>,
    /// Damage met so far, in file order.
    damage: Vec<Damage>,
    /// Chunk records met (whole framing), and whether that count is each chunk's ordinal in
    /// the file (no region of unknown content skipped before it).
    chunks: u64,
    ordinals_known: bool,
    /// Message-index entries after each chunk met (index: its ordinal - 1).
    indexed: Vec<Option<u64>>,
    /// The schemas and channels the summary repeats, registered at the first damage (the
    /// chunk lost may be the one that defined them).
    fallback: Option<(Vec<crate::summary::OwnedSchema>, Vec<records::Channel>)>,
    /// Raw payload bytes that may still be kept ([`Options::raw_limit`]), and whether some
    /// were dropped.
    raw_left: u64,
    raw_truncated: bool,
}

/// What decoding a chunk on a worker needs to know (a channel's topic never changes once
/// known, so an older snapshot is never wrong, only less complete).
type Snapshot = (Arc<Vec<usize>>, Arc<Vec<(String, Kind)>>);

/// A chunk waiting in a batch: its header and compressed records (copied out of the reader).
struct Pending {
    header: ChunkHeader,
    data: Vec<u8>,
    at: ChunkAt,
}

/// Where a chunk is: its record's offset and end, its ordinal (1-based, file order; 0 when
/// unknown).
#[derive(Clone, Copy)]
struct ChunkAt {
    offset: u64,
    end: u64,
    ordinal: u64,
}

/// A batch is decoded when it holds this many chunks...
const BATCH_CHUNKS: usize = 64;
/// ... or would inflate to this many bytes.
const BATCH_BYTES: u64 = 32 << 20;

/// One typed message of a chunk to decode: topic index, log time, payload.
type Work<'a> = (usize, i64, &'a [u8]);

/// Protobuf messages reused from message to message (their vectors keep their capacity).
#[derive(Default)]
struct Scratch {
    hand: PosesInFrame,
    pose: PoseInFrame,
}

/// Decode one message of topic `name` (log time `t`) into its track `kind`.
fn decode_into(
    kind: &mut Kind,
    scratch: &mut Scratch,
    path: &str,
    name: &str,
    t: i64,
    data: &[u8],
) {
    match kind {
        Kind::Hand(track, bad) => {
            let index = track.t_ns.len();
            track.t_ns.push(t);
            let m = &mut scratch.hand;
            m.clear();
            match m.merge(data) {
                Ok(()) if m.poses.len() == KP => {
                    for p in &m.poses {
                        let v = p.position.unwrap_or_default();
                        track.keypoints.extend_from_slice(&[v.x, v.y, v.z]);
                    }
                }
                Ok(()) => {
                    track.keypoints.extend_from_slice(&[f64::NAN; KP * 3]);
                    bad.push(Bad {
                        index,
                        t,
                        decode: false,
                        text: format!(
                            "{}: hand message at {t} ns has {} poses, not 21",
                            path,
                            m.poses.len()
                        ),
                    });
                }
                Err(err) => {
                    track.keypoints.extend_from_slice(&[f64::NAN; KP * 3]);
                    bad.push(Bad {
                        index,
                        t,
                        decode: true,
                        text: format!(
                            "{path}: cannot decode a foxglove.PosesInFrame on {name} at {t} ns: \
                             {err}"
                        ),
                    });
                }
            }
        }
        Kind::Pose(track, bad) => {
            let index = track.t_ns.len();
            track.t_ns.push(t);
            let m = &mut scratch.pose;
            m.clear();
            match m.merge(data) {
                Ok(()) => {
                    let pose = m.pose.unwrap_or_default();
                    let p = pose.position.unwrap_or_default();
                    let q = pose.orientation.unwrap_or_default();
                    track.position.extend_from_slice(&[p.x, p.y, p.z]);
                    track.quaternion.extend_from_slice(&[q.x, q.y, q.z, q.w]);
                }
                Err(err) => {
                    track.position.extend_from_slice(&[f64::NAN; 3]);
                    track.quaternion.extend_from_slice(&[f64::NAN; 4]);
                    bad.push(Bad {
                        index,
                        t,
                        decode: true,
                        text: format!(
                            "{path}: cannot decode a foxglove.PoseInFrame on {name} at {t} ns: \
                             {err}"
                        ),
                    });
                }
            }
        }
        Kind::Confidence(track) => {
            track.t_ns.push(t);
            match confidence(data) {
                Ok((values, visible)) => {
                    track.confidence.extend_from_slice(&values);
                    if let Some(v) = visible {
                        track.visible.extend_from_slice(&v);
                        track.has_visible.push(true);
                    } else {
                        track.visible.extend_from_slice(&[false; KP]);
                        track.has_visible.push(false);
                    }
                }
                Err(why) => {
                    track.confidence.extend_from_slice(&[f64::NAN; KP]);
                    track.visible.extend_from_slice(&[false; KP]);
                    track.has_visible.push(false);
                    if track.bad.is_none() {
                        track.bad = Some(format!("{path}: {name} at {t} ns: {why}"));
                    }
                }
            }
        }
        Kind::Raw(raw) => raw.push(t, data),
        Kind::Dropped => {}
    }
}

/// The batch a worker sends back (a pool thread waiting for it keeps helping the pool, so a
/// read from inside a rayon pool cannot deadlock).
fn wait(rx: &Receiver<Vec<Chunked>>) -> Vec<Chunked> {
    if rayon::current_thread_index().is_none() {
        return rx.recv().expect("a decoding worker panicked");
    }
    loop {
        match rx.try_recv() {
            Ok(batch) => return batch,
            Err(TryRecvError::Empty) => {
                if rayon::yield_now() != Some(rayon::Yield::Executed) {
                    std::thread::yield_now();
                }
            }
            Err(TryRecvError::Disconnected) => panic!("a decoding worker panicked"),
        }
    }
}

/// What a worker made of a chunk.
enum Chunked {
    /// Inflation failed: the chunk is lost, the pass goes on.
    Damaged(ChunkAt, String),
    /// Every message decoded (see [`decode_chunk`]).
    Done(Decoded),
    /// The inflated records, for the sequential path.
    Slow(ChunkAt, Vec<u8>),
}

/// A chunk decoded on a worker.
struct Decoded {
    /// Topic index and log time of each message, in order (for the channel summaries).
    messages: Vec<(u32, i64)>,
    /// The chunk's messages by topic, each topic in the order of its first message.
    parts: Vec<(usize, Kind)>,
}

/// Decode the records of an inflated chunk, when that needs nothing a sequential pass would
/// learn on the way: `None` when the chunk defines a schema or channel, has a message on a
/// channel not in `channels`, a log time beyond `i64::MAX`, or damage (the sequential path
/// then reads it and gives the verdict).
fn decode_chunk(
    records: &[u8],
    channels: &[usize],
    topics: &[(String, Kind)],
    path: &str,
) -> Option<Decoded> {
    let mut data = records;
    let mut scratch = Scratch::default();
    let mut messages = Vec::new();
    let mut parts: Vec<(usize, Kind)> = Vec::new();
    // topic index -> slot in `parts` (small: a chunk holds a few topics)
    let mut slots: Vec<(usize, usize)> = Vec::new();
    while !data.is_empty() {
        let (opcode, body, tail) = records::next_record(data).ok()?;
        data = tail;
        match opcode {
            op::MESSAGE => {
                let (ch, t, payload) = parse_message(body).ok()?;
                let i = channels[usize::from(ch)];
                if i == usize::MAX {
                    return None;
                }
                let t = i64::try_from(t).ok()?;
                messages.push((u32::try_from(i).ok()?, t));
                let (name, kind) = &topics[i];
                if matches!(kind, Kind::Dropped) {
                    continue;
                }
                let slot = if let Some(&(_, k)) = slots.iter().find(|(j, _)| *j == i) {
                    k
                } else {
                    parts.push((i, kind.empty()));
                    slots.push((i, parts.len() - 1));
                    parts.len() - 1
                };
                decode_into(&mut parts[slot].1, &mut scratch, path, name, t, payload);
            }
            op::SCHEMA | op::CHANNEL => return None,
            _ => {}
        }
    }
    Some(Decoded { messages, parts })
}

/// A parsed record of a chunk.
enum Item<'a> {
    Message(u16, u64, &'a [u8]),
    Other(Record<'a>),
}

/// A record that changes the reader's state.
enum Record<'a> {
    Header(String),
    Schema(records::Schema<'a>),
    Channel(records::Channel),
    Metadata(records::Metadata),
    DataEnd(u32),
    Footer,
    /// Anything else (message indexes, attachments, summary records): nothing to do.
    Other,
}

/// Parse a record other than a message or chunk.
fn parse(opcode: u8, body: &[u8]) -> Result<Record<'_>, String> {
    Ok(match opcode {
        op::HEADER => Record::Header(records::header(body)?.library),
        op::SCHEMA => Record::Schema(records::schema(body)?),
        op::CHANNEL => Record::Channel(records::channel(body)?),
        op::METADATA => Record::Metadata(records::metadata(body)?),
        op::DATA_END => Record::DataEnd(records::data_end(body)?),
        op::FOOTER => {
            records::footer(body)?;
            Record::Footer
        }
        _ => Record::Other,
    })
}

#[derive(PartialEq, Eq)]
enum Flow {
    Continue,
    Footer,
}

impl State {
    fn kind_for(&self, topic: &str, encoding: &str) -> Kind {
        let hand = topic == "/hand/right/keypoints" || topic == "/hand/left/keypoints";
        let conf = topic == "/hand/right/confidence" || topic == "/hand/left/confidence";
        if hand && encoding == "protobuf" {
            Kind::Hand(HandTrack::default(), Vec::new())
        } else if conf && encoding == "json" {
            Kind::Confidence(ConfidenceTrack::default())
        } else if is_object_topic(topic) && encoding == "protobuf" {
            Kind::Pose(PoseTrack::default(), Vec::new())
        } else if !self.options.keeps(topic) {
            Kind::Dropped
        } else {
            Kind::Raw(RawMessages::default())
        }
    }

    fn channel(&mut self, ch: records::Channel) {
        if self.channels[usize::from(ch.id)] != usize::MAX {
            return;
        }
        let schema = self.schemas.get(&ch.schema_id);
        if let Some(&i) = self.by_topic.get(&ch.topic) {
            let topic = &self.topics[i];
            let name = schema.map_or("", |s| s.name.as_str());
            let typed = !matches!(topic.kind, Kind::Raw(_) | Kind::Dropped);
            let (a, b) = (&topic.summary, (name, ch.message_encoding.as_str()));
            if typed && (a.schema.as_str(), a.encoding.as_str()) != b {
                // its messages are not decoded as the topic's type; the file is refused
                self.conflict.get_or_insert_with(|| {
                    format!(
                        "{}: {} carries two message types, {} ({}) and {} ({}); an lfd recording \
                         has one per topic",
                        self.path, ch.topic, a.schema, a.encoding, b.0, b.1
                    )
                });
                return;
            }
            self.channels[usize::from(ch.id)] = i;
            self.snapshot = None;
            return;
        }
        let summary = ChannelSummary {
            topic: ch.topic.clone(),
            schema: schema.map(|s| s.name.clone()).unwrap_or_default(),
            schema_encoding: schema.map(|s| s.encoding.clone()).unwrap_or_default(),
            schema_data: schema.map(|s| s.data.clone()).unwrap_or_default(),
            encoding: ch.message_encoding.clone(),
            metadata: ch.metadata.into_iter().collect(),
            count: 0,
            first_ns: None,
            last_ns: None,
        };
        let kind = self.kind_for(&ch.topic, &ch.message_encoding);
        self.topics.push(Topic { summary, kind });
        self.by_topic.insert(ch.topic, self.topics.len() - 1);
        self.channels[usize::from(ch.id)] = self.topics.len() - 1;
        self.snapshot = None;
    }

    /// The topic of a message on `channel` (None: unknown channel, skipped) and its log time,
    /// counted; raw payloads are stored here, typed ones left to the caller to decode.
    fn resolve(
        &mut self,
        channel: u16,
        t: u64,
        data: &[u8],
    ) -> Result<Option<(usize, i64)>, ReadError> {
        let i = self.channels[usize::from(channel)];
        if i == usize::MAX {
            return Ok(None); // a message before its channel: not something lfd wrote
        }
        let t = log_time(&self.path, &self.topics[i].summary.topic, t)?;
        self.topics[i].summary.add(t);
        let raw = matches!(self.topics[i].kind, Kind::Raw(_));
        if raw && !self.spend(data.len()) {
            return Ok(None);
        }
        let topic = &mut self.topics[i];
        match &mut topic.kind {
            Kind::Raw(raw) => {
                raw.push(t, data);
                Ok(None)
            }
            Kind::Dropped => Ok(None),
            _ => Ok(Some((i, t))),
        }
    }

    /// A message outside any chunk: resolved and decoded at once.
    fn message(&mut self, channel: u16, t: u64, data: &[u8]) -> Result<(), ReadError> {
        if let Some((i, t)) = self.resolve(channel, t, data)? {
            let topic = &mut self.topics[i];
            decode_into(
                &mut topic.kind,
                &mut self.scratch,
                &self.path,
                &topic.summary.topic,
                t,
                data,
            );
        }
        Ok(())
    }

    /// Handle a (non-message, non-chunk) record.
    fn record(&mut self, rec: Record<'_>) -> Flow {
        match rec {
            Record::Header(library) => self.library = library,
            Record::Schema(schema) => {
                self.schemas.insert(
                    schema.id,
                    Schema {
                        name: schema.name,
                        encoding: schema.encoding,
                        data: schema.data.to_vec(),
                    },
                );
            }
            Record::Channel(ch) => self.channel(ch),
            Record::Metadata(m) => merge_metadata(&mut self.metadata, m.name, m.metadata),
            Record::DataEnd(_) => self.data_done = true,
            Record::Footer => return Flow::Footer,
            Record::Other => {}
        }
        Flow::Continue
    }

    /// Whether `n` more bytes of raw payloads may be kept (spent if so).
    fn spend(&mut self, n: usize) -> bool {
        if n as u64 > self.raw_left {
            self.raw_truncated = true;
            return false;
        }
        self.raw_left -= n as u64;
        true
    }

    /// Register the summary's schemas and channels not met yet (after damage).
    fn fall_back(&mut self) {
        let Some((schemas, channels)) = self.fallback.take() else {
            return;
        };
        for s in schemas {
            self.schemas.entry(s.id).or_insert(Schema {
                name: s.name,
                encoding: s.encoding,
                data: s.data,
            });
        }
        for ch in channels {
            self.channel(ch);
        }
    }

    /// A chunk lost to damage (`why`).
    fn lost(&mut self, at: ChunkAt, why: String) {
        self.fall_back();
        let known = at.ordinal > 0;
        self.damage.push(Damage {
            offset: at.offset,
            end: at.end,
            chunks: known.then(|| vec![at.ordinal]),
            messages: if known {
                self.indexed.get(at.ordinal as usize - 1).copied().flatten()
            } else {
                None
            },
            why: format!("chunk at offset {}: {why}", at.offset),
        });
    }

    /// Handle a chunk record at `offset` (`end`: where the record ends): admitted (the bomb
    /// check) and queued.
    fn chunk(&mut self, body: &[u8], offset: u64, end: u64) -> Result<Flow, Stop> {
        let (header, data) = records::chunk(body).map_err(Stop::Record)?;
        if let Err(e) = self.budget.admit(&self.path, &header, data.len()) {
            self.flush()?; // damage in an earlier chunk comes first
            return Err(Stop::Fatal(e));
        }
        self.chunks += 1;
        self.indexed.push(None);
        let ordinal = if self.ordinals_known { self.chunks } else { 0 };
        self.pending_bytes += header.uncompressed_size;
        self.pending.push(Pending {
            header,
            data: data.to_vec(),
            at: ChunkAt {
                offset,
                end,
                ordinal,
            },
        });
        let chunks = BATCH_CHUNKS.min(1 << self.batches.min(16));
        if self.pending.len() >= chunks || self.pending_bytes >= BATCH_BYTES {
            self.submit()?;
        }
        Ok(Flow::Continue)
    }

    /// Handle any record of the file (`opcode`, `body`, at `offset`, `crc`: of the bytes
    /// before it), in file order: chunks are admitted and queued; any record that changes the
    /// state first decodes the queue. A record that does not parse is `Stop::Record`.
    fn top(&mut self, opcode: u8, body: &[u8], offset: u64, crc: u32) -> Result<Flow, Stop> {
        let end = offset + 9 + body.len() as u64;
        match opcode {
            op::CHUNK => self.chunk(body, offset, end),
            op::MESSAGE => {
                let (ch, t, data) = parse_message(body).map_err(Stop::Record)?;
                self.flush()?;
                self.message(ch, t, data).map_err(Stop::Fatal)?;
                Ok(Flow::Continue)
            }
            op::MESSAGE_INDEX => {
                let (_, entries) = records::message_index(body).map_err(Stop::Record)?;
                if let Some(n) = self.indexed.last_mut() {
                    *n = Some(n.unwrap_or(0) + entries.len() as u64 / 16);
                }
                Ok(Flow::Continue)
            }
            op::HEADER | op::SCHEMA | op::CHANNEL | op::METADATA | op::DATA_END | op::FOOTER => {
                let rec = parse(opcode, body).map_err(Stop::Record)?;
                self.flush()?;
                if let Record::DataEnd(expected) = rec {
                    if expected != 0 && expected != crc && self.damage.is_empty() {
                        self.damage.push(Damage {
                            offset: 0,
                            end: offset,
                            chunks: Some(Vec::new()),
                            messages: None,
                            why: format!(
                                "the data section's CRC is {crc}, its data-end record says \
                                 {expected}: a record outside the CRC-checked chunks is damaged"
                            ),
                        });
                    }
                }
                Ok(self.record(rec))
            }
            _ => Ok(Flow::Continue), // attachments, summary records, user records
        }
    }

    /// The channel map and topics for the workers.
    fn snapshot(&mut self) -> Snapshot {
        if self.snapshot.is_none() {
            let topics = self
                .topics
                .iter()
                .map(|t| (t.summary.topic.clone(), t.kind.empty()))
                .collect();
            self.snapshot = Some((Arc::new(self.channels.clone()), Arc::new(topics)));
        }
        self.snapshot.clone().expect("just made")
    }

    /// Queue the pending chunks: the workers inflate and decode them (see [`decode_chunk`])
    /// while the batch queued before is applied here, and the next one read.
    fn submit(&mut self) -> Result<(), Stop> {
        let pending = std::mem::take(&mut self.pending);
        self.pending_bytes = 0;
        self.batches += 1;
        let (channels, topics) = self.snapshot();
        let path = self.path.clone();
        let (tx, rx) = std::sync::mpsc::channel();
        rayon::spawn(move || {
            let decoded = pending
                .into_par_iter()
                .map(|p| match inflate(&p.header, &p.data) {
                    Err(why) => Chunked::Damaged(p.at, why),
                    Ok(records) => match decode_chunk(&records, &channels, &topics, &path) {
                        Some(decoded) => Chunked::Done(decoded),
                        None => Chunked::Slow(p.at, records.into_owned()),
                    },
                })
                .collect::<Vec<Chunked>>();
            let _ = tx.send(decoded); // (no receiver: the pass stopped before this batch)
        });
        if let Some(before) = self.inflight.replace(rx) {
            if let Err(stop) = self.apply(wait(&before)) {
                self.inflight = None; // damage in the batch before: this one is never read
                return Err(stop);
            }
        }
        Ok(())
    }

    /// Read every queued chunk (before a record that changes the state, and at the end).
    fn flush(&mut self) -> Result<(), Stop> {
        if !self.pending.is_empty() {
            self.submit()?;
        }
        match self.inflight.take() {
            Some(rx) => self.apply(wait(&rx)),
            None => Ok(()),
        }
    }

    /// Apply a batch, in file order: the decoded chunks are counted and appended; any other
    /// chunk is parsed (a chunk is all or nothing), its channels registered and its messages
    /// decoded here, as a sequential pass would.
    fn apply(&mut self, batch: Vec<Chunked>) -> Result<(), Stop> {
        for chunk in batch {
            match chunk {
                Chunked::Damaged(at, why) => self.lost(at, why),
                Chunked::Done(decoded) => {
                    for &(i, t) in &decoded.messages {
                        self.topics[i as usize].summary.add(t);
                    }
                    for (i, kind) in decoded.parts {
                        if let Kind::Raw(m) = &kind {
                            if !self.spend(m.data.len()) {
                                continue;
                            }
                        }
                        self.topics[i].kind.append(kind);
                    }
                }
                Chunked::Slow(at, records) => {
                    let work = match self.apply_chunk(&records) {
                        Ok(work) => work,
                        Err(Stop::Record(why)) => {
                            self.lost(at, why);
                            continue;
                        }
                        Err(stop) => return Err(stop),
                    };
                    let mut scratch = std::mem::take(&mut self.scratch);
                    for (i, t, data) in work {
                        let topic = &mut self.topics[i];
                        let name = &topic.summary.topic;
                        decode_into(&mut topic.kind, &mut scratch, &self.path, name, t, data);
                    }
                    self.scratch = scratch;
                }
            }
        }
        Ok(())
    }

    /// Parse every record of an inflated chunk (Python's `breakup_chunk` reads schemas,
    /// channels and messages, and skips the rest), then apply them: the typed messages are
    /// returned for decoding.
    fn apply_chunk<'a>(&mut self, records: &'a [u8]) -> Result<Vec<Work<'a>>, Stop> {
        let split = split_records(records).map_err(Stop::Record)?;
        let mut items = Vec::with_capacity(split.len());
        for (opcode, body) in split {
            match opcode {
                op::MESSAGE => {
                    let (ch, t, d) = parse_message(body).map_err(Stop::Record)?;
                    items.push(Item::Message(ch, t, d));
                }
                op::SCHEMA | op::CHANNEL => {
                    items.push(Item::Other(parse(opcode, body).map_err(Stop::Record)?));
                }
                _ => {}
            }
        }
        let mut work = Vec::with_capacity(items.len());
        for item in items {
            match item {
                Item::Message(ch, t, d) => {
                    if let Some((i, t)) = self.resolve(ch, t, d).map_err(Stop::Fatal)? {
                        work.push((i, t, d));
                    }
                }
                Item::Other(rec) => {
                    self.record(rec);
                }
            }
        }
        Ok(work)
    }

    fn finish(mut self, stop: Option<Stop>, file_size: u64) -> Result<Recording, ReadError> {
        if let Some(conflict) = self.conflict.take() {
            return Err(ReadError(conflict));
        }
        // chunks still queued come before whatever ended the pass
        let stop = match self.flush() {
            Err(s) => Some(s),
            Ok(()) => stop,
        };
        let mut rec = Recording {
            library: self.library,
            file_size,
            complete: self.data_done,
            metadata: self.metadata,
            ..Recording::default()
        };
        match stop {
            Some(Stop::Fatal(e)) => return Err(e),
            Some(Stop::Damaged(why) | Stop::Record(why)) if !self.data_done => {
                rec.error = Some(format!("incomplete or damaged record: {why}"));
            }
            _ if !self.data_done => {
                rec.error = Some("file ends without a data-end record (writer not closed)".into());
            }
            _ => {}
        }
        rec.damage = self.damage;
        rec.raw_truncated = self.raw_truncated;
        rec.chunks = self.chunks;
        for t in self.topics {
            let name = t.summary.topic.clone();
            rec.channels.push(t.summary);
            match t.kind {
                Kind::Hand(mut track, bad) => {
                    track.bad = pick_bad(&track.t_ns, bad);
                    rec.hands.push((name, track));
                }
                Kind::Pose(mut track, bad) => {
                    track.bad = pick_bad(&track.t_ns, bad);
                    rec.poses.push((name, track));
                }
                Kind::Confidence(track) => rec.confidence.push((name, track)),
                Kind::Raw(items) => rec.raw.push((name, items)),
                Kind::Dropped => {}
            }
        }
        Ok(rec)
    }
}

/// Text of a JSON value for an error message (at most 80 characters, as Python's
/// `str(values)[:80]`).
fn short(v: &Value) -> String {
    let mut s = String::new();
    py_str(v, &mut s);
    s.chars().take(80).collect()
}

/// Python's `str()` of a parsed JSON value (lists `[1, 2]`, `True`, `None`, `'text'`).
fn py_str(v: &Value, out: &mut String) {
    match v {
        Value::Null => out.push_str("None"),
        Value::Bool(true) => out.push_str("True"),
        Value::Bool(false) => out.push_str("False"),
        Value::Number(n) => {
            if n.is_f64() {
                let x = n.as_f64().unwrap_or(f64::NAN);
                if x.fract() == 0.0 && x.abs() < 1e16 {
                    let _ = write!(out, "{x:.1}");
                } else {
                    out.push_str(&x.to_string());
                }
            } else {
                out.push_str(&n.to_string());
            }
        }
        Value::String(text) => out.push_str(&crate::py_str_repr(text)),
        Value::Array(items) => {
            out.push('[');
            for (i, item) in items.iter().enumerate() {
                if i > 0 {
                    out.push_str(", ");
                }
                py_str(item, out);
                if out.len() > 400 {
                    break; // only the first 80 characters are shown
                }
            }
            out.push(']');
        }
        Value::Object(map) => {
            out.push('{');
            for (i, (k, item)) in map.iter().enumerate() {
                if i > 0 {
                    out.push_str(", ");
                }
                out.push_str(&crate::py_str_repr(k));
                out.push_str(": ");
                py_str(item, out);
                if out.len() > 400 {
                    break;
                }
            }
            out.push('}');
        }
    }
}

fn is_unit_number(v: &Value) -> Option<f64> {
    let x = v.as_f64()?;
    (x.is_finite() && (0.0..=1.0).contains(&x)).then_some(x)
}

type ConfidenceRow = ([f64; KP], Option<[bool; KP]>);

/// The shape of a valid confidence message, parsed without building a JSON tree.
#[derive(serde::Deserialize)]
struct FastConfidence {
    confidence: [f64; KP],
    #[serde(default)]
    visible: Option<[bool; KP]>,
}

/// The 21 confidences and, if given, visibilities of one `{"confidence": [...], "visible":
/// [...]}` message, validated as `lfd.io.reader._confidence`.
fn confidence(data: &[u8]) -> Result<ConfidenceRow, String> {
    // The fast path accepts only valid messages; anything else is looked at again as a JSON
    // tree, for the exact verdict and its words.
    // (a struct also deserialises from a JSON array: only objects take the fast path)
    let object = data.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'{');
    if let Some(fast) = object
        .then(|| serde_json::from_slice::<FastConfidence>(data).ok())
        .flatten()
    {
        let values = fast.confidence;
        if values
            .iter()
            .all(|x| x.is_finite() && (0.0..=1.0).contains(x))
        {
            return Ok((values, fast.visible));
        }
    }
    confidence_slow(data)
}

fn confidence_slow(data: &[u8]) -> Result<ConfidenceRow, String> {
    let not_object =
        |why: String| format!("not a JSON object {{\"confidence\": [21 numbers]}} ({why})");
    let record: Value = serde_json::from_slice(data).map_err(|e| not_object(e.to_string()))?;
    let values = match &record {
        Value::Object(map) => match map.get("confidence") {
            Some(v) => v,
            None => return Err(not_object("KeyError('confidence')".into())),
        },
        Value::Array(_) => {
            return Err(not_object(
                "TypeError('list indices must be integers or slices, not str')".into(),
            ))
        }
        Value::String(_) => {
            return Err(not_object(
                "TypeError(\"string indices must be integers, not 'str'\")".into(),
            ))
        }
        other => {
            let class = match other {
                Value::Bool(_) => "bool",
                Value::Number(n) if n.is_f64() => "float",
                Value::Number(_) => "int",
                _ => "NoneType",
            };
            return Err(not_object(format!(
                "TypeError(\"'{class}' object is not subscriptable\")"
            )));
        }
    };
    let mut out = [0.0; KP];
    let ok = match values {
        Value::Array(items) if items.len() == KP => items
            .iter()
            .zip(out.iter_mut())
            .all(|(v, slot)| is_unit_number(v).map(|x| *slot = x).is_some()),
        _ => false,
    };
    if !ok {
        return Err(format!(
            "confidence must be 21 numbers in [0, 1], got {}",
            short(values)
        ));
    }
    let visible = match record.get("visible") {
        None | Some(Value::Null) => None,
        Some(v) => {
            let mut vis = [false; KP];
            let ok = match v {
                Value::Array(items) if items.len() == KP => items
                    .iter()
                    .zip(vis.iter_mut())
                    .all(|(v, slot)| v.as_bool().map(|b| *slot = b).is_some()),
                _ => false,
            };
            if !ok {
                return Err(format!("visible must be 21 booleans, got {}", short(v)));
            }
            Some(vis)
        }
    };
    Ok((out, visible))
}

/// Read every complete chunk of the MCAP file at `path` (see the crate documentation).
///
/// # Errors
/// A [`ReadError`] worded as `lfd.io.mcapfile.scan` when the file cannot be opened, is empty,
/// does not start with the MCAP magic, would inflate beyond [`crate::inflate_limit`], uses an
/// unknown chunk compression, or has a message with a log time beyond `i64::MAX`. Damage
/// after the magic is not an error ([`Recording::complete`], [`Recording::error`],
/// [`Recording::damage`]).
pub fn read_recording(path: &Path, options: &Options) -> Result<Recording, ReadError> {
    let (file, size) = open_checked(path)?;
    read_source(
        Source::File(&file),
        size,
        &path.display().to_string(),
        options,
    )
}

/// [`read_recording`] of a file's bytes held in memory (`path` names it in messages): what
/// the fuzz harness calls.
///
/// # Errors
/// As [`read_recording`].
pub fn read_recording_bytes(
    bytes: &[u8],
    path: &str,
    options: &Options,
) -> Result<Recording, ReadError> {
    crate::check_magic(bytes, bytes.len() as u64, path)?;
    read_source(Source::Bytes(bytes), bytes.len() as u64, path, options)
}

fn read_source(
    src: Source<'_>,
    size: u64,
    path: &str,
    options: &Options,
) -> Result<Recording, ReadError> {
    let mut state = State {
        path: path.to_string(),
        options: options.clone(),
        budget: Budget::new(size),
        library: String::new(),
        schemas: HashMap::new(),
        channels: vec![usize::MAX; 1 << 16],
        scratch: Scratch::default(),
        topics: Vec::new(),
        by_topic: HashMap::new(),
        metadata: Vec::new(),
        data_done: false,
        conflict: None,
        pending: Vec::new(),
        pending_bytes: 0,
        batches: 0,
        inflight: None,
        snapshot: None,
        damage: Vec::new(),
        chunks: 0,
        ordinals_known: true,
        indexed: Vec::new(),
        fallback: crate::summary::channels(src, size),
        raw_left: options.raw_limit.unwrap_or(u64::MAX),
        raw_truncated: false,
    };
    let mut walker = Walker::new(src, size, 0);
    let stop = match walker.advance(crate::MAGIC.len() as u64) {
        Ok(()) => run(&mut state, &mut walker),
        Err(e) => Some(Stop::Damaged(format!("cannot read the file: {e}"))),
    };
    let mut rec = state.finish(stop, size)?;
    if !rec.damage.is_empty() {
        if let Some(n) = crate::summary::attribute(src, size, &mut rec.damage) {
            rec.chunks = n;
        }
    }
    Ok(rec)
}

/// The pass over the top-level records: each handled in order; a damaged one stepped over
/// to the next plausible record (a region of [`Damage`]), or, with none after it (a cut
/// file), the end of the pass.
fn run(state: &mut State, w: &mut Walker<'_>) -> Option<Stop> {
    loop {
        let (offset, why) = match w.next() {
            Next::End => return None,
            Next::Cut(why) => return Some(Stop::Damaged(why)),
            Next::Damaged { offset, why } => (offset, why),
            Next::Record {
                offset,
                opcode,
                len,
            } => {
                let crc = w.crc();
                let body = match w.body(offset, len) {
                    Ok(body) => body,
                    Err(e) => return Some(Stop::Damaged(format!("cannot read the file: {e}"))),
                };
                match state.top(opcode, body, offset, crc) {
                    Ok(Flow::Continue) => {
                        if let Err(e) = w.advance(offset + 9 + len) {
                            return Some(Stop::Damaged(format!("cannot read the file: {e}")));
                        }
                        continue;
                    }
                    Ok(Flow::Footer) => return None,
                    Err(Stop::Record(why)) => (
                        offset,
                        format!(
                            "a {} record at offset {offset} is damaged: {why}",
                            records::opcode_name(opcode)
                        ),
                    ),
                    Err(stop) => return Some(stop),
                }
            }
        };
        if state.data_done {
            return Some(Stop::Damaged(why)); // in the summary section: nothing more to read
        }
        let max_chunk = crate::MAX_CHUNK_BYTES;
        let Some(to) = w.resync(offset, max_chunk) else {
            return Some(Stop::Damaged(why));
        };
        state.ordinals_known = false;
        if let Err(stop) = state.flush() {
            return Some(stop);
        }
        state.fall_back();
        state.damage.push(Damage {
            offset,
            end: to,
            chunks: None,
            messages: None,
            why,
        });
        if let Err(e) = w.advance(to) {
            return Some(Stop::Damaged(format!("cannot read the file: {e}")));
        }
    }
}
