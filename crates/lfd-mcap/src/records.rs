//! The MCAP records lfd reads, parsed by hand from a record's body: every length and count a
//! record holds is checked against the bytes that remain in it *before* anything is taken or
//! allocated, so a damaged length can never reserve more than the record itself (the `mcap`
//! crate's parser reserves a declared string or map length up front: 4 GiB for a length of
//! 2^32 - 1). An error is one plain line naming the record and the field.

use std::collections::BTreeMap;

/// The opcodes of the MCAP records (the MCAP specification's numbers).
pub mod op {
    pub const HEADER: u8 = 0x01;
    pub const FOOTER: u8 = 0x02;
    pub const SCHEMA: u8 = 0x03;
    pub const CHANNEL: u8 = 0x04;
    pub const MESSAGE: u8 = 0x05;
    pub const CHUNK: u8 = 0x06;
    pub const MESSAGE_INDEX: u8 = 0x07;
    pub const CHUNK_INDEX: u8 = 0x08;
    pub const ATTACHMENT: u8 = 0x09;
    pub const ATTACHMENT_INDEX: u8 = 0x0A;
    pub const STATISTICS: u8 = 0x0B;
    pub const METADATA: u8 = 0x0C;
    pub const METADATA_INDEX: u8 = 0x0D;
    pub const SUMMARY_OFFSET: u8 = 0x0E;
    pub const DATA_END: u8 = 0x0F;
}

/// A record's name, for messages.
pub fn opcode_name(opcode: u8) -> String {
    let name = match opcode {
        op::HEADER => "header",
        op::FOOTER => "footer",
        op::SCHEMA => "schema",
        op::CHANNEL => "channel",
        op::MESSAGE => "message",
        op::CHUNK => "chunk",
        op::MESSAGE_INDEX => "message index",
        op::CHUNK_INDEX => "chunk index",
        op::ATTACHMENT => "attachment",
        op::ATTACHMENT_INDEX => "attachment index",
        op::STATISTICS => "statistics",
        op::METADATA => "metadata",
        op::METADATA_INDEX => "metadata index",
        op::SUMMARY_OFFSET => "summary offset",
        op::DATA_END => "data end",
        other => return format!("opcode {other:#04x}"),
    };
    name.to_string()
}

/// Whether `opcode` is one the MCAP specification defines.
pub fn known(opcode: u8) -> bool {
    (op::HEADER..=op::DATA_END).contains(&opcode)
}

/// A reading position in one record's body.
pub struct Cursor<'a> {
    data: &'a [u8],
    what: &'static str,
}

impl<'a> Cursor<'a> {
    pub fn new(data: &'a [u8], what: &'static str) -> Self {
        Self { data, what }
    }

    fn short(&self, field: &str, need: u64) -> String {
        format!(
            "a {} record's {field} needs {need} bytes, {} are left in it",
            self.what,
            self.data.len()
        )
    }

    /// The next `n` bytes (`n` checked against what remains first).
    pub fn take(&mut self, n: u64, field: &str) -> Result<&'a [u8], String> {
        if n > self.data.len() as u64 {
            return Err(self.short(field, n));
        }
        let (head, rest) = self.data.split_at(n as usize);
        self.data = rest;
        Ok(head)
    }

    pub fn u8(&mut self, field: &str) -> Result<u8, String> {
        Ok(self.take(1, field)?[0])
    }

    pub fn u16(&mut self, field: &str) -> Result<u16, String> {
        let b = self.take(2, field)?;
        Ok(u16::from_le_bytes([b[0], b[1]]))
    }

    pub fn u32(&mut self, field: &str) -> Result<u32, String> {
        let b = self.take(4, field)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    pub fn u64(&mut self, field: &str) -> Result<u64, String> {
        let mut b = [0u8; 8];
        b.copy_from_slice(self.take(8, field)?);
        Ok(u64::from_le_bytes(b))
    }

    /// A `u32`-prefixed byte string.
    pub fn bytes32(&mut self, field: &str) -> Result<&'a [u8], String> {
        let n = self.u32(field)?;
        self.take(u64::from(n), field)
    }

    /// A `u64`-prefixed byte string.
    pub fn bytes64(&mut self, field: &str) -> Result<&'a [u8], String> {
        let n = self.u64(field)?;
        self.take(n, field)
    }

    /// A `u32`-prefixed UTF-8 string.
    pub fn string(&mut self, field: &str) -> Result<String, String> {
        let b = self.bytes32(field)?;
        String::from_utf8(b.to_vec())
            .map_err(|_| format!("a {} record's {field} is not UTF-8", self.what))
    }

    /// A map of strings to strings (`u32` byte length, then key/value pairs); a repeated key
    /// keeps its last value.
    pub fn string_map(&mut self, field: &str) -> Result<BTreeMap<String, String>, String> {
        let mut inner = Cursor::new(self.bytes32(field)?, self.what);
        let mut map = BTreeMap::new();
        while !inner.data.is_empty() {
            let k = inner.string(field)?;
            let v = inner.string(field)?;
            map.insert(k, v);
        }
        Ok(map)
    }

    /// A map of `u16` to `u64` (`u32` byte length, 10-byte entries).
    pub fn int_map(&mut self, field: &str) -> Result<BTreeMap<u16, u64>, String> {
        let mut inner = Cursor::new(self.bytes32(field)?, self.what);
        let mut map = BTreeMap::new();
        while !inner.data.is_empty() {
            let k = inner.u16(field)?;
            let v = inner.u64(field)?;
            map.insert(k, v);
        }
        Ok(map)
    }

    /// Everything left.
    pub fn rest(&mut self) -> &'a [u8] {
        std::mem::take(&mut self.data)
    }

    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
}

pub struct Header {
    pub library: String,
}

pub fn header(body: &[u8]) -> Result<Header, String> {
    let mut c = Cursor::new(body, "header");
    c.string("profile")?;
    Ok(Header {
        library: c.string("library")?,
    })
}

pub struct Footer {
    pub summary_start: u64,
    pub summary_crc: u32,
}

pub fn footer(body: &[u8]) -> Result<Footer, String> {
    let mut c = Cursor::new(body, "footer");
    let summary_start = c.u64("summary start")?;
    c.u64("summary offset start")?;
    Ok(Footer {
        summary_start,
        summary_crc: c.u32("summary crc")?,
    })
}

pub struct Schema<'a> {
    pub id: u16,
    pub name: String,
    pub encoding: String,
    pub data: &'a [u8],
}

pub fn schema(body: &[u8]) -> Result<Schema<'_>, String> {
    let mut c = Cursor::new(body, "schema");
    Ok(Schema {
        id: c.u16("id")?,
        name: c.string("name")?,
        encoding: c.string("encoding")?,
        data: c.bytes32("data")?,
    })
}

pub struct Channel {
    pub id: u16,
    pub schema_id: u16,
    pub topic: String,
    pub message_encoding: String,
    pub metadata: BTreeMap<String, String>,
}

pub fn channel(body: &[u8]) -> Result<Channel, String> {
    let mut c = Cursor::new(body, "channel");
    Ok(Channel {
        id: c.u16("id")?,
        schema_id: c.u16("schema id")?,
        topic: c.string("topic")?,
        message_encoding: c.string("message encoding")?,
        metadata: c.string_map("metadata")?,
    })
}

/// A message record's channel id, log time and payload.
pub fn message(body: &[u8]) -> Result<(u16, u64, &[u8]), String> {
    if body.len() < 22 {
        return Err(format!(
            "a message record of {} bytes is shorter than its 22-byte header",
            body.len()
        ));
    }
    let channel = u16::from_le_bytes([body[0], body[1]]);
    let mut t = [0u8; 8];
    t.copy_from_slice(&body[6..14]);
    Ok((channel, u64::from_le_bytes(t), &body[22..]))
}

/// A chunk's header (its records follow).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChunkHeader {
    pub message_start_time: u64,
    pub message_end_time: u64,
    pub uncompressed_size: u64,
    pub uncompressed_crc: u32,
    pub compression: String,
}

/// A chunk record: its header and its (compressed) records.
pub fn chunk(body: &[u8]) -> Result<(ChunkHeader, &[u8]), String> {
    let mut c = Cursor::new(body, "chunk");
    chunk_from(&mut c)
}

fn chunk_from<'a>(c: &mut Cursor<'a>) -> Result<(ChunkHeader, &'a [u8]), String> {
    let header = ChunkHeader {
        message_start_time: c.u64("message start time")?,
        message_end_time: c.u64("message end time")?,
        uncompressed_size: c.u64("uncompressed size")?,
        uncompressed_crc: c.u32("uncompressed crc")?,
        compression: c.string("compression")?,
    };
    let records = c.bytes64("records")?;
    Ok((header, records))
}

/// Whether a chunk record of `body` is one a writer made: its records end exactly where the
/// record ends, a known compression, start time <= end time, a size within `max_size` (how
/// a reader that lost its place recognises the next chunk).
pub fn plausible_chunk(body: &[u8], max_size: u64) -> bool {
    let mut c = Cursor::new(body, "chunk");
    let Ok((header, _)) = chunk_from(&mut c) else {
        return false;
    };
    c.is_empty()
        && matches!(header.compression.as_str(), "" | "zstd" | "lz4")
        && header.message_start_time <= header.message_end_time
        && header.uncompressed_size <= max_size
}

pub struct Metadata {
    pub name: String,
    pub metadata: BTreeMap<String, String>,
}

pub fn metadata(body: &[u8]) -> Result<Metadata, String> {
    let mut c = Cursor::new(body, "metadata");
    Ok(Metadata {
        name: c.string("name")?,
        metadata: c.string_map("metadata")?,
    })
}

pub fn data_end(body: &[u8]) -> Result<u32, String> {
    Cursor::new(body, "data end").u32("data section crc")
}

/// Entries of a message index record (channel id, number of `(time, offset)` entries).
pub fn message_index(body: &[u8]) -> Result<(u16, &[u8]), String> {
    let mut c = Cursor::new(body, "message index");
    let channel = c.u16("channel id")?;
    let entries = c.bytes32("entries")?;
    if entries.len() % 16 != 0 {
        return Err(format!(
            "a message index record's entries take {} bytes, not a multiple of 16",
            entries.len()
        ));
    }
    Ok((channel, entries))
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChunkIndex {
    pub message_start_time: u64,
    pub message_end_time: u64,
    pub chunk_start_offset: u64,
    pub chunk_length: u64,
    pub message_index_offsets: BTreeMap<u16, u64>,
    pub message_index_length: u64,
    pub compression: String,
    pub compressed_size: u64,
    pub uncompressed_size: u64,
}

pub fn chunk_index(body: &[u8]) -> Result<ChunkIndex, String> {
    let mut c = Cursor::new(body, "chunk index");
    Ok(ChunkIndex {
        message_start_time: c.u64("message start time")?,
        message_end_time: c.u64("message end time")?,
        chunk_start_offset: c.u64("chunk start offset")?,
        chunk_length: c.u64("chunk length")?,
        message_index_offsets: c.int_map("message index offsets")?,
        message_index_length: c.u64("message index length")?,
        compression: c.string("compression")?,
        compressed_size: c.u64("compressed size")?,
        uncompressed_size: c.u64("uncompressed size")?,
    })
}

pub struct AttachmentIndex {
    pub log_time: u64,
    pub data_size: u64,
    pub name: String,
    pub media_type: String,
}

pub fn attachment_index(body: &[u8]) -> Result<AttachmentIndex, String> {
    let mut c = Cursor::new(body, "attachment index");
    c.u64("offset")?;
    c.u64("length")?;
    let log_time = c.u64("log time")?;
    c.u64("create time")?;
    Ok(AttachmentIndex {
        log_time,
        data_size: c.u64("data size")?,
        name: c.string("name")?,
        media_type: c.string("media type")?,
    })
}

pub struct Statistics {
    pub message_count: u64,
    pub chunk_count: u32,
    pub channel_message_counts: BTreeMap<u16, u64>,
}

pub fn statistics(body: &[u8]) -> Result<Statistics, String> {
    let mut c = Cursor::new(body, "statistics");
    let message_count = c.u64("message count")?;
    c.u16("schema count")?;
    c.u32("channel count")?;
    c.u32("attachment count")?;
    c.u32("metadata count")?;
    let chunk_count = c.u32("chunk count")?;
    c.u64("message start time")?;
    c.u64("message end time")?;
    Ok(Statistics {
        message_count,
        chunk_count,
        channel_message_counts: c.int_map("channel message counts")?,
    })
}

pub struct MetadataIndex {
    pub offset: u64,
}

pub fn metadata_index(body: &[u8]) -> Result<MetadataIndex, String> {
    let mut c = Cursor::new(body, "metadata index");
    Ok(MetadataIndex {
        offset: c.u64("offset")?,
    })
}

/// The first record of `data` (an inflated chunk or a summary section): `(opcode, body, the
/// bytes after it)`, or why it cannot be one (a header cut short, a length past the end).
pub fn next_record(data: &[u8]) -> Result<(u8, &[u8], &[u8]), String> {
    if data.len() < 9 {
        return Err("a chunk ends inside a record header".into());
    }
    let opcode = data[0];
    let mut l = [0u8; 8];
    l.copy_from_slice(&data[1..9]);
    let len = u64::from_le_bytes(l);
    let rest = &data[9..];
    if len > rest.len() as u64 {
        return Err(format!(
            "a {} record of {len} bytes runs past its chunk ({} bytes left)",
            opcode_name(opcode),
            rest.len()
        ));
    }
    let (body, tail) = rest.split_at(len as usize);
    Ok((opcode, body, tail))
}

/// The records of an inflated chunk (or a summary section): `(opcode, body)`, all of them or
/// an error.
pub fn split(mut data: &[u8]) -> Result<Vec<(u8, &[u8])>, String> {
    let mut out = Vec::new();
    while !data.is_empty() {
        let (opcode, body, tail) = next_record(data)?;
        out.push((opcode, body));
        data = tail;
    }
    Ok(out)
}
