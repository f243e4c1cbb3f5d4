//! The top-level records of a file, one after the other, through a window of the file (a few
//! MiB), never trusting a length: a record's length is checked against the bytes left in the
//! file before its body is read, and a record whose framing is damaged (a length running past
//! the file, an unknown opcode, a record that does not parse) is stepped over by searching
//! forward for the next record a writer plausibly made ([`Walker::resync`]).

use std::fs::File;
use std::os::unix::fs::FileExt;

use crate::records::{self, op};

/// Bytes read from the file per read (at least).
const READ_BLOCK: usize = 1 << 20;

/// A metadata, schema or channel record larger than this is not taken as a resynchronisation
/// point (its body would have to be read to be checked).
const SYNC_BODY: u64 = 1 << 20;

/// Where the bytes come from: a file (read with `pread`) or memory.
#[derive(Clone, Copy)]
pub(crate) enum Source<'a> {
    File(&'a File),
    Bytes(&'a [u8]),
}

impl Source<'_> {
    /// Fill `buf` from `offset` (the caller keeps it within the source).
    pub fn read_at(&self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        match self {
            Source::File(f) => f.read_exact_at(buf, offset),
            Source::Bytes(b) => {
                let start = usize::try_from(offset).map_err(std::io::Error::other)?;
                let src = b
                    .get(start..start + buf.len())
                    .ok_or_else(|| std::io::Error::from(std::io::ErrorKind::UnexpectedEof))?;
                buf.copy_from_slice(src);
                Ok(())
            }
        }
    }

    /// `len` bytes at `offset`, `None` past the end (`len` checked against `size` first).
    pub fn bytes_at(&self, offset: u64, len: u64, size: u64) -> Option<Vec<u8>> {
        if offset.checked_add(len)? > size {
            return None;
        }
        let mut buf = vec![0u8; usize::try_from(len).ok()?];
        self.read_at(offset, &mut buf).ok()?;
        Some(buf)
    }
}

/// What the next record is.
pub(crate) enum Next {
    /// A record at `offset`: its opcode and the length of its body (within the file).
    Record { offset: u64, opcode: u8, len: u64 },
    /// The record at `offset` is damaged (`why`): resynchronise.
    Damaged { offset: u64, why: String },
    /// The file ends exactly here.
    End,
    /// The file ends inside a record header, or a read failed.
    Cut(String),
}

/// A linear pass over the top-level records of a source.
pub(crate) struct Walker<'a> {
    pub src: Source<'a>,
    pub size: u64,
    /// Bytes of the source from `buf_start`.
    buf: Vec<u8>,
    buf_start: u64,
    /// Offset of the next record.
    pub pos: u64,
    /// CRC of the bytes `[0, hashed)`.
    crc: crc32fast::Hasher,
    hashed: u64,
}

impl<'a> Walker<'a> {
    pub fn new(src: Source<'a>, size: u64, pos: u64) -> Self {
        Self {
            src,
            size,
            buf: Vec::new(),
            buf_start: 0,
            pos,
            crc: crc32fast::Hasher::new(),
            hashed: 0,
        }
    }

    /// The `len` bytes at `offset` (which the caller keeps within the source), through the
    /// window.
    pub fn window(&mut self, offset: u64, len: u64) -> std::io::Result<&[u8]> {
        let end = offset + len;
        let have = self.buf_start + self.buf.len() as u64;
        if offset < self.buf_start || end > have {
            let n = len.max(READ_BLOCK as u64).min(self.size - offset);
            let n = usize::try_from(n).map_err(std::io::Error::other)?;
            self.buf.clear();
            self.buf.resize(n, 0);
            self.buf_start = offset;
            if let Err(e) = self.src.read_at(offset, &mut self.buf) {
                self.buf.clear();
                return Err(e);
            }
        }
        let at = (offset - self.buf_start) as usize;
        Ok(&self.buf[at..at + len as usize])
    }

    /// The next record's header.
    pub fn next(&mut self) -> Next {
        let offset = self.pos;
        let left = self.size - offset;
        if left == 0 {
            return Next::End;
        }
        if left < 9 {
            return Next::Cut(format!(
                "the file ends inside a record header ({left} bytes at offset {offset})"
            ));
        }
        let head = match self.window(offset, 9) {
            Ok(h) => h,
            Err(e) => return Next::Cut(format!("cannot read the file: {e}")),
        };
        let opcode = head[0];
        let mut l = [0u8; 8];
        l.copy_from_slice(&head[1..9]);
        let len = u64::from_le_bytes(l);
        if !records::known(opcode) && opcode < 0x80 {
            return Next::Damaged {
                offset,
                why: format!("unknown record opcode {opcode:#04x} at offset {offset}"),
            };
        }
        if len > left - 9 {
            return Next::Damaged {
                offset,
                why: format!(
                    "a {} record at offset {offset} declares {len} bytes, more than the {} left \
                     in the file",
                    records::opcode_name(opcode),
                    left - 9
                ),
            };
        }
        Next::Record {
            offset,
            opcode,
            len,
        }
    }

    /// The body of the record `next` returned.
    pub fn body(&mut self, offset: u64, len: u64) -> std::io::Result<&[u8]> {
        self.window(offset + 9, len)
    }

    /// Move to `to` (after the current record, or to a resynchronisation point), hashing the
    /// bytes passed.
    pub fn advance(&mut self, to: u64) -> std::io::Result<()> {
        while self.hashed < to {
            let n = (to - self.hashed).min(READ_BLOCK as u64);
            let at = self.hashed;
            self.window(at, n)?;
            let from = (at - self.buf_start) as usize;
            self.crc.update(&self.buf[from..from + n as usize]);
            self.hashed += n;
        }
        self.pos = to;
        Ok(())
    }

    /// CRC of the bytes before the current position (the data section's, at the data-end
    /// record).
    pub fn crc(&self) -> u32 {
        self.crc.clone().finalize()
    }

    /// The first offset after `from` where a record a writer plausibly made starts (a chunk,
    /// a message index, schema, channel or metadata record whose fields end exactly where
    /// its length says, a data-end record followed by a summary record), `None` if none.
    pub fn resync(&mut self, from: u64, max_chunk: u64) -> Option<u64> {
        let mut start = from + 1;
        while start + 9 <= self.size {
            let n = (self.size - start).min(READ_BLOCK as u64);
            let found = {
                let block = self.window(start, n).ok()?.to_vec();
                block.iter().enumerate().find_map(|(i, &b)| {
                    let at = start + i as u64;
                    (matches!(
                        b,
                        op::CHUNK
                            | op::MESSAGE_INDEX
                            | op::SCHEMA
                            | op::CHANNEL
                            | op::METADATA
                            | op::DATA_END
                    ) && self.plausible(at, max_chunk))
                    .then_some(at)
                })
            };
            if found.is_some() {
                return found;
            }
            start += n.saturating_sub(8).max(1);
        }
        None
    }

    /// Whether a plausible record starts at `at` (read directly, not through the window).
    fn plausible(&self, at: u64, max_chunk: u64) -> bool {
        let Some(head) = self.src.bytes_at(at, 9, self.size) else {
            return false;
        };
        let opcode = head[0];
        let len = u64::from_le_bytes(head[1..9].try_into().unwrap_or_default());
        let left = self.size - at - 9;
        if len > left {
            return false;
        }
        match opcode {
            op::CHUNK => {
                // the header up to the compression (at most "zstd"), then the records' length
                let n = len.min(8 + 8 + 8 + 4 + 4 + 4 + 8);
                let Some(body) = self.src.bytes_at(at + 9, n, self.size) else {
                    return false;
                };
                if body.len() < 32 {
                    return false;
                }
                let clen = u32::from_le_bytes(body[28..32].try_into().unwrap_or_default());
                if clen > 4 || body.len() < 32 + clen as usize + 8 {
                    return false;
                }
                let r = 32 + clen as usize;
                let records = u64::from_le_bytes(body[r..r + 8].try_into().unwrap_or_default());
                let mut whole = body[..r + 8].to_vec();
                whole.resize(r + 8, 0);
                // the records' length must close the record exactly
                records.checked_add(r as u64 + 8) == Some(len)
                    && records::plausible_chunk(&with_records(&whole, records), max_chunk)
            }
            op::MESSAGE_INDEX => {
                let Some(body) = self.src.bytes_at(at + 9, 6.min(len), self.size) else {
                    return false;
                };
                body.len() == 6 && {
                    let n = u32::from_le_bytes(body[2..6].try_into().unwrap_or_default());
                    u64::from(n) + 6 == len && n % 16 == 0
                }
            }
            op::SCHEMA | op::CHANNEL | op::METADATA => {
                if !(4..=SYNC_BODY).contains(&len) {
                    return false;
                }
                let Some(body) = self.src.bytes_at(at + 9, len, self.size) else {
                    return false;
                };
                match opcode {
                    op::SCHEMA => exact(&body, |c| {
                        c.u16("")?;
                        c.string("")?;
                        c.string("")?;
                        c.bytes32("")?;
                        Ok(())
                    }),
                    op::CHANNEL => exact(&body, |c| {
                        c.u16("")?;
                        c.u16("")?;
                        c.string("")?;
                        c.string("")?;
                        c.string_map("")?;
                        Ok(())
                    }),
                    _ => exact(&body, |c| {
                        c.string("")?;
                        c.string_map("")?;
                        Ok(())
                    }),
                }
            }
            op::DATA_END => {
                len == 4 && {
                    let next = at + 9 + 4;
                    self.src.bytes_at(next, 9, self.size).is_some_and(|h| {
                        let l = u64::from_le_bytes(h[1..9].try_into().unwrap_or_default());
                        matches!(
                            h[0],
                            op::FOOTER
                                | op::SCHEMA
                                | op::CHANNEL
                                | op::CHUNK_INDEX
                                | op::ATTACHMENT_INDEX
                                | op::STATISTICS
                                | op::METADATA_INDEX
                                | op::SUMMARY_OFFSET
                        ) && l <= self.size - next - 9
                    })
                }
            }
            _ => false,
        }
    }
}

/// A chunk header (`head`: its fields and the records' length) as a body whose records are
/// `records` bytes long, for [`records::plausible_chunk`] (the records themselves are not
/// read: zeros of that length, at most a few bytes are ever looked at).
fn with_records(head: &[u8], records: u64) -> Vec<u8> {
    // plausible_chunk only checks that the records fill the body: a body of the header alone
    // with the length set to 0 says the same once the length is known to close the record.
    let _ = records;
    let mut body = head.to_vec();
    let r = body.len() - 8;
    body[r..].copy_from_slice(&0u64.to_le_bytes());
    body
}

/// Whether `parse` reads `body` to its last byte without error.
fn exact(body: &[u8], parse: impl FnOnce(&mut records::Cursor<'_>) -> Result<(), String>) -> bool {
    let mut c = records::Cursor::new(body, "record");
    parse(&mut c).is_ok() && c.is_empty()
}
