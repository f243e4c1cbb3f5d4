//! [`read_summary`]: a finished recording's summary section, without a pass over its data.
//!
//! Nothing in a summary is believed beyond what it can be checked against: the section must
//! pass its CRC, a chunk index repeated is one chunk, every chunk index must point at a chunk
//! record inside the data section (no two overlapping) whose header agrees with it, every
//! chunk must have its message indexes (their times inside the chunk's span), and the
//! statistics must agree with what the message indexes count. Every chunk is then inflated and
//! CRC-checked (in parallel, nothing kept), so a damaged chunk is named
//! ([`Summary::damage`]) with the messages its message indexes say it held. A summary that
//! fails a check is not used: the caller reads the whole file instead.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use rayon::prelude::*;

use crate::inflate::{check, messages, Budget};
use crate::records::{self, op, ChunkIndex};
use crate::scan::{log_time, merge_metadata};
use crate::walk::Source;
use crate::{open_checked, AttachmentInfo, ChannelSummary, Damage, ReadError, Summary, MAGIC};

/// Footer record (opcode, length, 20-byte body) and the closing magic.
const FOOTER_TAIL: u64 = 1 + 8 + 20 + 8;

/// The summary is unusable (no footer, damaged, not to be believed): the caller reads the
/// whole file instead.
struct Unusable;

impl From<String> for Unusable {
    fn from(_: String) -> Self {
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

impl From<String> for Fail {
    fn from(_: String) -> Self {
        Fail::Unusable
    }
}

fn read_at(src: Source<'_>, offset: u64, len: u64, size: u64) -> Result<Vec<u8>, Unusable> {
    src.bytes_at(offset, len, size).ok_or(Unusable)
}

/// One record `(opcode, body)` starting at `offset` (its length bounded by the file).
fn record_at(src: Source<'_>, offset: u64, size: u64) -> Result<(u8, Vec<u8>), Unusable> {
    let head = read_at(src, offset, 9, size)?;
    let len = u64::from_le_bytes(head[1..9].try_into().map_err(|_| Unusable)?);
    let body = read_at(src, offset.checked_add(9).ok_or(Unusable)?, len, size)?;
    Ok((head[0], body))
}

/// The records of a summary section, parsed and checked.
#[derive(Default)]
struct Section {
    library: String,
    schemas: HashMap<u16, (String, String, Vec<u8>)>,
    channels: Vec<records::Channel>,
    /// Distinct chunks, by offset.
    chunks: Vec<ChunkIndex>,
    meta_index: Vec<records::MetadataIndex>,
    attachments: Vec<AttachmentInfo>,
    statistics: Option<records::Statistics>,
}

/// The footer, the summary section (CRC-checked) and its records.
fn section(src: Source<'_>, size: u64) -> Result<Section, Unusable> {
    if size < MAGIC.len() as u64 + FOOTER_TAIL {
        return Err(Unusable);
    }
    let footer_at = size - FOOTER_TAIL;
    let tail = read_at(src, footer_at, FOOTER_TAIL, size)?;
    if tail[29..] != MAGIC[..] || tail[0] != op::FOOTER || tail[1..9] != 20u64.to_le_bytes() {
        return Err(Unusable);
    }
    let footer = records::footer(&tail[9..29])?;
    let start = footer.summary_start;
    // the data-end record (13 bytes) comes right before the summary
    if start < MAGIC.len() as u64 + 13 || start > footer_at {
        return Err(Unusable);
    }
    let bytes = read_at(src, start, footer_at - start, size)?;
    if footer.summary_crc != 0 {
        let mut h = crc32fast::Hasher::new();
        h.update(&bytes);
        h.update(&tail[..25]);
        if h.finalize() != footer.summary_crc {
            return Err(Unusable);
        }
    }
    let data_end = start - 13;
    let end_record = read_at(src, data_end, 9, size)?;
    if end_record[0] != op::DATA_END || end_record[1..9] != 4u64.to_le_bytes() {
        return Err(Unusable);
    }
    let mut out = Section::default();
    // the library: the header record right after the magic
    if let Ok((op::HEADER, body)) = record_at(src, MAGIC.len() as u64, size) {
        if let Ok(h) = records::header(&body) {
            out.library = h.library;
        }
    }
    let mut chunks = BTreeMap::new();
    for (opcode, body) in records::split(&bytes)? {
        match opcode {
            op::SCHEMA => {
                let s = records::schema(body)?;
                out.schemas
                    .entry(s.id)
                    .or_insert((s.name, s.encoding, s.data.to_vec()));
            }
            op::CHANNEL => out.channels.push(records::channel(body)?),
            op::CHUNK_INDEX => {
                let ci = records::chunk_index(body)?;
                // a repeated index is the same chunk; two different ones at one offset: damage
                if chunks
                    .insert(ci.chunk_start_offset, ci.clone())
                    .is_some_and(|old| old != ci)
                {
                    return Err(Unusable);
                }
            }
            op::METADATA_INDEX => out.meta_index.push(records::metadata_index(body)?),
            op::ATTACHMENT_INDEX => {
                let ai = records::attachment_index(body)?;
                out.attachments.push(AttachmentInfo {
                    name: ai.name,
                    media_type: ai.media_type,
                    log_time: ai.log_time,
                    size: ai.data_size,
                });
            }
            op::STATISTICS => out.statistics = Some(records::statistics(body)?),
            _ => {}
        }
    }
    out.chunks = chunks.into_values().collect();
    // every chunk inside the data section, none overlapping the next
    let mut at = MAGIC.len() as u64;
    for ci in &out.chunks {
        let end = ci
            .chunk_start_offset
            .checked_add(ci.chunk_length)
            .and_then(|e| e.checked_add(ci.message_index_length))
            .ok_or(Unusable)?;
        if ci.chunk_start_offset < at || end > data_end {
            return Err(Unusable);
        }
        at = end;
    }
    Ok(out)
}

/// Messages per channel, and their time span, from the message indexes after a chunk.
type Counts = (BTreeMap<u16, u64>, BTreeMap<u16, (u64, u64)>);

/// The message indexes of `ci`: counts and spans by channel (`Unusable`: missing, damaged, or
/// times outside the chunk's span).
fn chunk_counts(src: Source<'_>, size: u64, ci: &ChunkIndex) -> Result<Counts, Unusable> {
    let mut counts = BTreeMap::new();
    let mut spans: BTreeMap<u16, (u64, u64)> = BTreeMap::new();
    let at = ci
        .chunk_start_offset
        .checked_add(ci.chunk_length)
        .ok_or(Unusable)?;
    let index = read_at(src, at, ci.message_index_length, size)?;
    for (opcode, body) in records::split(&index)? {
        if opcode != op::MESSAGE_INDEX {
            continue;
        }
        let (channel, entries) = records::message_index(body)?;
        *counts.entry(channel).or_default() += (entries.len() / 16) as u64;
        let times = entries
            .chunks_exact(16)
            .map(|e| u64::from_le_bytes(e[..8].try_into().unwrap_or_default()));
        if let (Some(lo), Some(hi)) = (times.clone().min(), times.max()) {
            // message indexes are outside the (CRC-checked) summary: a time outside its
            // chunk's span is damage
            if lo < ci.message_start_time || hi > ci.message_end_time {
                return Err(Unusable);
            }
            let s = spans.entry(channel).or_insert((lo, hi));
            s.0 = s.0.min(lo);
            s.1 = s.1.max(hi);
        }
    }
    Ok((counts, spans))
}

/// The chunk record at `ci`, if it agrees with its index: its header and compressed records.
fn chunk_at(
    src: Source<'_>,
    size: u64,
    ci: &ChunkIndex,
) -> Result<(records::ChunkHeader, Vec<u8>), String> {
    let (opcode, body) = record_at(src, ci.chunk_start_offset, size)
        .map_err(|Unusable| "its record runs past the file".to_string())?;
    if opcode != op::CHUNK || body.len() as u64 + 9 != ci.chunk_length {
        return Err(format!(
            "no chunk record of {} bytes where the chunk index says",
            ci.chunk_length
        ));
    }
    let (header, data) = records::chunk(&body)?;
    if header.uncompressed_size != ci.uncompressed_size
        || data.len() as u64 != ci.compressed_size
        || header.compression != ci.compression
    {
        return Err("its header disagrees with its chunk index".into());
    }
    Ok((header, data.to_vec()))
}

/// The summary section of the MCAP file at `path`: library, channels (message counts and exact
/// first/last log times, from the message indexes), metadata (through the metadata indexes),
/// attachments, the message count, the damaged chunks (every chunk is inflated and
/// CRC-checked, nothing kept), and the raw messages of `topics` (reading only the chunks that
/// hold them, within the inflation budget). `None` when the file has no usable summary (a
/// killed recording, no footer, a damaged summary, chunks without message indexes, statistics
/// that disagree with the indexes): read it with [`crate::read_recording`] instead.
///
/// # Errors
/// The errors of [`crate::read_recording`] for a file that cannot be opened or is no MCAP
/// file, a chunk that would be a decompression bomb or has an unknown compression, and a log
/// time beyond `i64::MAX`.
pub fn read_summary(path: &Path, topics: &[String]) -> Result<Option<Summary>, ReadError> {
    let (file, size) = open_checked(path)?;
    from_source(
        Source::File(&file),
        size,
        &path.display().to_string(),
        topics,
    )
}

/// [`read_summary`] of a file's bytes held in memory (`path` names it in messages).
///
/// # Errors
/// As [`read_summary`].
pub fn read_summary_bytes(
    bytes: &[u8],
    path: &str,
    topics: &[String],
) -> Result<Option<Summary>, ReadError> {
    crate::check_magic(bytes, bytes.len() as u64, path)?;
    from_source(Source::Bytes(bytes), bytes.len() as u64, path, topics)
}

fn from_source(
    src: Source<'_>,
    size: u64,
    path: &str,
    topics: &[String],
) -> Result<Option<Summary>, ReadError> {
    match summary(src, size, path, topics) {
        Ok(s) => Ok(Some(s)),
        Err(Fail::Unusable) => Ok(None),
        Err(Fail::Fatal(e)) => Err(e),
    }
}

/// The topics of the channel records (a repeated topic merged into the first) and the topic
/// index of each channel id.
fn topics_of(sec: &mut Section, out: &mut Summary) -> HashMap<u16, usize> {
    let mut by_topic: HashMap<String, usize> = HashMap::new();
    let mut topic_of: HashMap<u16, usize> = HashMap::new();
    for ch in std::mem::take(&mut sec.channels) {
        if topic_of.contains_key(&ch.id) {
            continue;
        }
        if let Some(&i) = by_topic.get(&ch.topic) {
            topic_of.insert(ch.id, i);
            continue;
        }
        let schema = sec.schemas.get(&ch.schema_id);
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
    topic_of
}

/// Messages per chunk (from its message indexes) and the channels' counts and spans, checked
/// against the statistics.
fn count(
    src: Source<'_>,
    size: u64,
    path: &str,
    sec: &Section,
    topic_of: &HashMap<u16, usize>,
    out: &mut Summary,
) -> Result<Vec<BTreeMap<u16, u64>>, Fail> {
    let mut counts: BTreeMap<u16, u64> = BTreeMap::new();
    let mut span: HashMap<usize, (u64, u64)> = HashMap::new();
    let mut per_chunk = Vec::with_capacity(sec.chunks.len());
    // a writer indexes every chunk's messages or none: a chunk without an index then holds
    // none (schemas and channels only); without any, nothing is counted here
    if !sec.chunks.is_empty() && sec.chunks.iter().all(|ci| ci.message_index_length == 0) {
        return Err(Fail::Unusable);
    }
    // no chunk index: only statistics saying "no message" are believed (messages outside
    // chunks, or no index at all, are counted by a full read)
    if sec.chunks.is_empty() && sec.statistics.as_ref().map(|s| s.message_count) != Some(0) {
        return Err(Fail::Unusable);
    }
    for ci in &sec.chunks {
        if ci.message_index_length == 0 {
            per_chunk.push(BTreeMap::new());
            continue;
        }
        let (c, spans) = chunk_counts(src, size, ci)?;
        for (&ch, &n) in &c {
            *counts.entry(ch).or_default() += n;
        }
        per_chunk.push(c);
        for (ch, (lo, hi)) in spans {
            if let Some(&i) = topic_of.get(&ch) {
                let s = span.entry(i).or_insert((lo, hi));
                s.0 = s.0.min(lo);
                s.1 = s.1.max(hi);
            }
        }
    }
    let total: u64 = counts.values().sum();
    if let Some(s) = &sec.statistics {
        // the statistics (CRC-checked) must agree with the message indexes
        let nonzero = |m: &BTreeMap<u16, u64>| -> BTreeMap<u16, u64> {
            m.iter()
                .filter(|(_, &n)| n > 0)
                .map(|(&k, &n)| (k, n))
                .collect()
        };
        if s.message_count != total
            || u64::from(s.chunk_count) != sec.chunks.len() as u64
            || (!s.channel_message_counts.is_empty()
                && nonzero(&s.channel_message_counts) != nonzero(&counts))
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
        c.first_ns = Some(log_time(path, &c.topic, first).map_err(Fail::Fatal)?);
        c.last_ns = Some(log_time(path, &c.topic, last).map_err(Fail::Fatal)?);
    }
    if out
        .channels
        .iter()
        .any(|c| c.count > 0 && c.first_ns.is_none())
    {
        return Err(Fail::Unusable);
    }
    out.messages = total;
    Ok(per_chunk)
}

fn summary(src: Source<'_>, size: u64, path: &str, topics: &[String]) -> Result<Summary, Fail> {
    let mut sec = section(src, size)?;
    let mut out = Summary {
        file_size: size,
        library: std::mem::take(&mut sec.library),
        attachments: std::mem::take(&mut sec.attachments),
        chunks: sec.chunks.len() as u64,
        ..Summary::default()
    };
    let topic_of = topics_of(&mut sec, &mut out);
    let per_chunk = count(src, size, path, &sec, &topic_of, &mut out)?;
    for mi in &sec.meta_index {
        let (opcode, body) = record_at(src, mi.offset, size)?;
        if opcode != op::METADATA {
            return Err(Fail::Unusable);
        }
        let m = records::metadata(&body)?;
        merge_metadata(&mut out.metadata, m.name, m.metadata);
    }
    let totals: Vec<u64> = per_chunk.iter().map(|c| c.values().sum()).collect();
    out.damage = verify(src, size, path, &sec.chunks, &totals)?;
    // the counts are what can be read: a damaged chunk's messages are not
    for d in &out.damage {
        for &k in d.chunks.iter().flatten() {
            for (ch, n) in &per_chunk[k as usize - 1] {
                if let Some(&i) = topic_of.get(ch) {
                    out.channels[i].count -= n;
                }
                out.messages -= n;
            }
        }
    }
    let damaged: Vec<u64> = out.damage.iter().map(|d| d.offset).collect();
    read_topics(
        src,
        size,
        path,
        topics,
        &sec.chunks,
        &damaged,
        &topic_of,
        &mut out,
    )?;
    Ok(out)
}

/// Inflate and CRC-check every chunk (in parallel, block by block, nothing kept): the damaged
/// ones.
fn verify(
    src: Source<'_>,
    size: u64,
    path: &str,
    chunks: &[ChunkIndex],
    per_chunk: &[u64],
) -> Result<Vec<Damage>, Fail> {
    // the bomb check first, in file order (as a full read would)
    let mut budget = Budget::new(size);
    for ci in chunks {
        let header = records::ChunkHeader {
            message_start_time: ci.message_start_time,
            message_end_time: ci.message_end_time,
            uncompressed_size: ci.uncompressed_size,
            uncompressed_crc: 0,
            compression: ci.compression.clone(),
        };
        let compressed = usize::try_from(ci.compressed_size).unwrap_or(usize::MAX);
        budget
            .admit(path, &header, compressed)
            .map_err(Fail::Fatal)?;
    }
    let damaged: Vec<Damage> = chunks
        .par_iter()
        .enumerate()
        .filter_map(|(i, ci)| {
            let why = match chunk_at(src, size, ci) {
                Err(why) => why,
                Ok((header, data)) => check(&header, &data).err()?,
            };
            Some(Damage {
                offset: ci.chunk_start_offset,
                end: ci.chunk_start_offset + ci.chunk_length,
                chunks: Some(vec![i as u64 + 1]),
                messages: Some(per_chunk[i]),
                why: format!("chunk at offset {}: {why}", ci.chunk_start_offset),
            })
        })
        .collect();
    Ok(damaged)
}

/// The schemas and channels a usable summary section repeats (what a reader that lost the
/// chunk defining a channel falls back on).
pub(crate) fn channels(
    src: Source<'_>,
    size: u64,
) -> Option<(Vec<OwnedSchema>, Vec<records::Channel>)> {
    let mut sec = section(src, size).ok()?;
    let schemas = sec
        .schemas
        .drain()
        .map(|(id, (name, encoding, data))| OwnedSchema {
            id,
            name,
            encoding,
            data,
        })
        .collect();
    Some((schemas, sec.channels))
}

/// A schema record, owned.
pub(crate) struct OwnedSchema {
    pub id: u16,
    pub name: String,
    pub encoding: String,
    pub data: Vec<u8>,
}

/// Name the chunks lost in each damaged region of a full read, and their messages, from the
/// file's summary when it has a usable one (chunk indexes and message indexes): the number of
/// chunks it indexes.
pub(crate) fn attribute(src: Source<'_>, size: u64, damage: &mut [Damage]) -> Option<u64> {
    let Ok(sec) = section(src, size) else {
        return None;
    };
    for d in damage.iter_mut() {
        if d.offset == 0 {
            continue; // the data section's CRC: no region
        }
        let lost: Vec<(u64, &ChunkIndex)> = sec
            .chunks
            .iter()
            .enumerate()
            .filter(|(_, ci)| ci.chunk_start_offset >= d.offset && ci.chunk_start_offset < d.end)
            .map(|(i, ci)| (i as u64 + 1, ci))
            .collect();
        d.chunks = Some(lost.iter().map(|(i, _)| *i).collect());
        d.messages = lost
            .iter()
            .map(|(_, ci)| {
                (ci.message_index_length > 0)
                    .then(|| chunk_counts(src, size, ci).ok())
                    .flatten()
                    .map(|(c, _)| c.values().sum::<u64>())
            })
            .sum();
    }
    Some(sec.chunks.len() as u64)
}

/// The raw messages of `topics`, from the chunks whose index lists one of their channels (a
/// damaged chunk is skipped: [`Summary::damage`] names it).
fn read_topics(
    src: Source<'_>,
    size: u64,
    path: &str,
    topics: &[String],
    chunks: &[ChunkIndex],
    damaged: &[u64],
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
    let mut left = crate::SUMMARY_RAW_LIMIT;
    for ci in chunks {
        if out.raw_truncated {
            break;
        }
        if !ci
            .message_index_offsets
            .keys()
            .any(|id| wanted.contains_key(id))
        {
            continue;
        }
        if damaged.contains(&ci.chunk_start_offset) {
            continue;
        }
        let Ok((header, data)) = chunk_at(src, size, ci) else {
            continue;
        };
        let mut fatal = None;
        let raw = &mut out.raw;
        let truncated = &mut out.raw_truncated;
        let _ = messages(
            &header,
            &data,
            |ch| wanted.contains_key(&ch),
            |ch, t, payload| {
                let r = wanted[&ch];
                let t = match log_time(path, &raw[r].0, t) {
                    Ok(t) => t,
                    Err(e) => {
                        fatal = Some(e);
                        return false;
                    }
                };
                if payload.len() as u64 > left {
                    *truncated = true;
                    return false;
                }
                left -= payload.len() as u64;
                raw[r].1.push(t, payload);
                true
            },
        );
        if let Some(e) = fatal {
            return Err(Fail::Fatal(e));
        }
    }
    Ok(())
}
