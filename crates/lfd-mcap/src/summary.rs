//! [`read_summary`]: a finished recording's summary section, without a pass over its data.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::os::unix::fs::FileExt;
use std::path::Path;

use mcap::records::{op, ChunkIndex, Record};

use crate::inflate::{inflate, Budget};
use crate::scan::{log_time, merge_metadata, parse_message, split_records};
use crate::{open_checked, AttachmentInfo, ChannelSummary, ReadError, Summary, MAGIC};

/// Footer record (opcode, length, 20-byte body) and the closing magic.
const FOOTER_TAIL: u64 = 1 + 8 + 20 + 8;

/// The summary is unusable (no footer, damaged): the caller reads the whole file instead.
struct Unusable;

impl From<mcap::McapError> for Unusable {
    fn from(_: mcap::McapError) -> Self {
        Unusable
    }
}

impl From<std::io::Error> for Unusable {
    fn from(_: std::io::Error) -> Self {
        Unusable
    }
}

enum Fail {
    Unusable,
    Fatal(ReadError),
}

impl From<Unusable> for Fail {
    fn from(_: Unusable) -> Self {
        Fail::Unusable
    }
}

impl From<mcap::McapError> for Fail {
    fn from(_: mcap::McapError) -> Self {
        Fail::Unusable
    }
}

fn read_at(file: &File, offset: u64, len: u64, size: u64) -> Result<Vec<u8>, Unusable> {
    let end = offset.checked_add(len).ok_or(Unusable)?;
    if end > size {
        return Err(Unusable);
    }
    let mut buf = vec![0u8; usize::try_from(len).map_err(|_| Unusable)?];
    file.read_exact_at(&mut buf, offset)?;
    Ok(buf)
}

/// One record `(opcode, body)` starting at `offset`.
fn record_at(file: &File, offset: u64, size: u64) -> Result<(u8, Vec<u8>), Unusable> {
    let head = read_at(file, offset, 9, size)?;
    let len = u64::from_le_bytes(head[1..9].try_into().map_err(|_| Unusable)?);
    let body = read_at(file, offset + 9, len, size)?;
    Ok((head[0], body))
}

/// The summary section of the MCAP file at `path`: library, channels (message counts and exact
/// first/last log times, from the statistics and the chunks' message indexes), metadata
/// (through the metadata indexes), attachments, the message count, and the raw messages of
/// `topics` (reading only the chunks that hold them, within the inflation budget). `None`
/// when the file has no usable summary (a killed recording, no footer, a damaged summary):
/// read it with [`crate::read_recording`] instead.
///
/// # Errors
/// The errors of [`crate::read_recording`] for a file that cannot be opened or is no MCAP
/// file, a chunk of `topics` that would be a decompression bomb or has an unknown
/// compression, and a log time beyond `i64::MAX`.
pub fn read_summary(path: &Path, topics: &[String]) -> Result<Option<Summary>, ReadError> {
    let (file, size) = open_checked(path)?;
    match summary(&file, size, &path.display().to_string(), topics) {
        Ok(s) => Ok(Some(s)),
        Err(Fail::Unusable) => Ok(None),
        Err(Fail::Fatal(e)) => Err(e),
    }
}

fn summary(file: &File, size: u64, path: &str, topics: &[String]) -> Result<Summary, Fail> {
    if size < MAGIC.len() as u64 + FOOTER_TAIL {
        return Err(Fail::Unusable);
    }
    let tail = read_at(file, size - FOOTER_TAIL, FOOTER_TAIL, size)?;
    if tail[29..] != MAGIC[..] || tail[0] != op::FOOTER || tail[1..9] != 20u64.to_le_bytes() {
        return Err(Fail::Unusable);
    }
    let Record::Footer(footer) = mcap::parse_record(op::FOOTER, &tail[9..29])? else {
        return Err(Fail::Unusable);
    };
    let footer_at = size - FOOTER_TAIL;
    let start = footer.summary_start;
    if start < MAGIC.len() as u64 || start > footer_at {
        return Err(Fail::Unusable);
    }
    let section = read_at(file, start, footer_at - start, size)?;
    if footer.summary_crc != 0 {
        let mut h = crc32fast::Hasher::new();
        h.update(&section);
        h.update(&tail[..25]);
        if h.finalize() != footer.summary_crc {
            return Err(Fail::Unusable);
        }
    }
    let mut out = Summary {
        file_size: size,
        ..Summary::default()
    };
    // the library: the header record right after the magic
    if let Ok((op::HEADER, body)) = record_at(file, MAGIC.len() as u64, size) {
        if let Ok(Record::Header(h)) = mcap::parse_record(op::HEADER, &body) {
            out.library = h.library;
        }
    }
    let mut schemas: HashMap<u16, (String, String, Vec<u8>)> = HashMap::new();
    let mut channels: Vec<mcap::records::Channel> = Vec::new();
    let mut chunks: Vec<ChunkIndex> = Vec::new();
    let mut meta_index = Vec::new();
    let mut statistics = None;
    for (opcode, body) in split_records(&section).map_err(|_| Fail::Unusable)? {
        match mcap::parse_record(opcode, body)? {
            Record::Schema { header, data } => {
                schemas.entry(header.id).or_insert((
                    header.name,
                    header.encoding,
                    data.into_owned(),
                ));
            }
            Record::Channel(ch) => channels.push(ch),
            Record::ChunkIndex(ci) => chunks.push(ci),
            Record::MetadataIndex(mi) => meta_index.push(mi),
            Record::AttachmentIndex(ai) => out.attachments.push(AttachmentInfo {
                name: ai.name,
                media_type: ai.media_type,
                log_time: ai.log_time,
                size: ai.data_size,
            }),
            Record::Statistics(s) => statistics = Some(s),
            _ => {}
        }
    }
    // topics in order of the channel records, a repeated topic merged into the first
    let mut by_topic: HashMap<String, usize> = HashMap::new();
    let mut topic_of: HashMap<u16, usize> = HashMap::new();
    for ch in channels {
        if topic_of.contains_key(&ch.id) {
            continue;
        }
        if let Some(&i) = by_topic.get(&ch.topic) {
            topic_of.insert(ch.id, i);
            continue;
        }
        let schema = schemas.get(&ch.schema_id);
        out.channels.push(ChannelSummary {
            topic: ch.topic.clone(),
            schema: schema.map(|s| s.0.clone()).unwrap_or_default(),
            schema_encoding: schema.map(|s| s.1.clone()).unwrap_or_default(),
            schema_data: schema.map(|s| s.2.clone()).unwrap_or_default(),
            encoding: ch.message_encoding,
            metadata: ch.metadata.into_iter().collect(),
            ..ChannelSummary::default()
        });
        by_topic.insert(ch.topic, out.channels.len() - 1);
        topic_of.insert(ch.id, out.channels.len() - 1);
    }
    chunks.sort_by_key(|c| c.chunk_start_offset);
    let message_count = statistics.as_ref().map(|s| s.message_count);
    if chunks.is_empty() && message_count != Some(0) {
        return Err(Fail::Unusable); // messages outside chunks (or no statistics): not indexed
    }
    // per-channel counts and time spans from the message indexes after each chunk
    let mut counts: BTreeMap<u16, u64> = BTreeMap::new();
    let mut span: HashMap<usize, (u64, u64)> = HashMap::new();
    for ci in &chunks {
        if ci.message_index_length == 0 {
            continue;
        }
        let at = ci
            .chunk_start_offset
            .checked_add(ci.chunk_length)
            .ok_or(Fail::Unusable)?;
        let index = read_at(file, at, ci.message_index_length, size)?;
        for (opcode, body) in split_records(&index).map_err(|_| Fail::Unusable)? {
            if opcode != op::MESSAGE_INDEX {
                continue;
            }
            // parsed by hand (no vector of entries): channel id, byte length, (time, offset)*
            if body.len() < 6 {
                return Err(Fail::Unusable);
            }
            let channel = u16::from_le_bytes([body[0], body[1]]);
            let n = u32::from_le_bytes([body[2], body[3], body[4], body[5]]) as usize;
            let entries = body.get(6..6 + n).ok_or(Fail::Unusable)?;
            if n % 16 != 0 {
                return Err(Fail::Unusable);
            }
            *counts.entry(channel).or_default() += (n / 16) as u64;
            let Some(&i) = topic_of.get(&channel) else {
                continue;
            };
            let times = entries.chunks_exact(16).map(|e| {
                let mut t = [0u8; 8];
                t.copy_from_slice(&e[..8]);
                u64::from_le_bytes(t)
            });
            if let (Some(lo), Some(hi)) = (times.clone().min(), times.max()) {
                // message indexes are outside the (CRC-checked) summary: a time outside its
                // chunk's span is damage
                if lo < ci.message_start_time || hi > ci.message_end_time {
                    return Err(Fail::Unusable);
                }
                let s = span.entry(i).or_insert((lo, hi));
                s.0 = s.0.min(lo);
                s.1 = s.1.max(hi);
            }
        }
    }
    if let Some(s) = &statistics {
        // the statistics (CRC-checked) must agree with the message indexes
        let nonzero = |m: &BTreeMap<u16, u64>| -> BTreeMap<u16, u64> {
            m.iter()
                .filter(|(_, &n)| n > 0)
                .map(|(&k, &n)| (k, n))
                .collect()
        };
        if !s.channel_message_counts.is_empty()
            && nonzero(&s.channel_message_counts) != nonzero(&counts)
        {
            return Err(Fail::Unusable);
        }
    }
    for (id, n) in &counts {
        if let Some(&i) = topic_of.get(id) {
            out.channels[i].count += n;
        }
    }
    for (i, (first, last)) in span {
        let c = &mut out.channels[i];
        let first = log_time(path, &c.topic, first).map_err(Fail::Fatal)?;
        let last = log_time(path, &c.topic, last).map_err(Fail::Fatal)?;
        c.first_ns = Some(first);
        c.last_ns = Some(last);
    }
    if out
        .channels
        .iter()
        .any(|c| c.count > 0 && c.first_ns.is_none())
    {
        return Err(Fail::Unusable); // no message index: no exact time span
    }
    out.messages = message_count.unwrap_or_else(|| counts.values().sum());
    for mi in meta_index {
        let (opcode, body) = record_at(file, mi.offset, size)?;
        if let Record::Metadata(m) = mcap::parse_record(opcode, &body)? {
            merge_metadata(&mut out.metadata, m.name, m.metadata);
        }
    }
    read_topics(file, size, path, topics, &chunks, &topic_of, &mut out)?;
    Ok(out)
}

/// The raw messages of `topics`, from the chunks whose index lists one of their channels.
fn read_topics(
    file: &File,
    size: u64,
    path: &str,
    topics: &[String],
    chunks: &[ChunkIndex],
    topic_of: &HashMap<u16, usize>,
    out: &mut Summary,
) -> Result<(), Fail> {
    // requested topic (index into out.channels) -> index into out.raw
    let mut raw_of: HashMap<usize, usize> = HashMap::new();
    for t in topics {
        if let Some(i) = out.channels.iter().position(|c| c.topic == *t) {
            if let std::collections::hash_map::Entry::Vacant(e) = raw_of.entry(i) {
                e.insert(out.raw.len());
                out.raw.push((t.clone(), crate::RawMessages::default()));
            }
        }
    }
    let wanted: HashMap<u16, usize> = topic_of
        .iter()
        .filter_map(|(id, i)| raw_of.get(i).map(|&r| (*id, r)))
        .collect();
    if wanted.is_empty() {
        return Ok(());
    }
    let mut budget = Budget::new(size);
    for ci in chunks {
        if !ci
            .message_index_offsets
            .keys()
            .any(|id| wanted.contains_key(id))
        {
            continue;
        }
        let (opcode, body) = record_at(file, ci.chunk_start_offset, size)?;
        if opcode != op::CHUNK {
            return Err(Fail::Unusable);
        }
        let Record::Chunk { header, data } = mcap::parse_record(opcode, &body)? else {
            return Err(Fail::Unusable);
        };
        budget
            .admit(path, &header, data.len())
            .map_err(Fail::Fatal)?;
        let records = inflate(&header, &data).map_err(|_| Fail::Unusable)?;
        for (opcode, body) in split_records(&records).map_err(|_| Fail::Unusable)? {
            if opcode != op::MESSAGE {
                continue;
            }
            let (ch, t, payload) = parse_message(body).map_err(|_| Fail::Unusable)?;
            if let Some(&r) = wanted.get(&ch) {
                let t = log_time(path, &out.raw[r].0, t).map_err(Fail::Fatal)?;
                out.raw[r].1.push(t, payload);
            }
        }
    }
    Ok(())
}
