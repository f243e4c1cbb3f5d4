//! Chunk inflation within a decompression-bomb budget (as `lfd.io.mcapfile._inflate`).
//!
//! [`Budget::admit`] checks a chunk's declared size (and its compression) in file order,
//! before anything is decompressed; [`inflate`] then decompresses it, possibly on another
//! thread, stopping one byte beyond the declared size.

use std::borrow::Cow;
use std::cell::RefCell;
use std::io::Read;

use crate::records::ChunkHeader;
use crate::{py_str_repr, ReadError, MAX_CHUNK_BYTES, MAX_INFLATION};

/// The remaining inflation budget of one file.
pub(crate) struct Budget {
    pub left: u64,
    pub file_size: u64,
}

impl Budget {
    pub fn new(file_size: u64) -> Self {
        Self {
            left: crate::inflate_limit(file_size),
            file_size,
        }
    }

    /// Admit a chunk of `compressed` bytes with `header`: its declared uncompressed size must
    /// fit the budget (it is then spent) and its compression must be known. Errors are worded
    /// as `scan()`'s.
    pub fn admit(
        &mut self,
        path: &str,
        header: &ChunkHeader,
        compressed: usize,
    ) -> Result<(), ReadError> {
        let n = header.uncompressed_size;
        let limit = self.left.min(MAX_CHUNK_BYTES);
        if n > limit {
            return Err(ReadError(format!(
                "{path}: a chunk of {compressed} bytes declares {n} uncompressed bytes, more \
                 than the {limit} bytes this {}-byte file may still inflate to \
                 ({MAX_INFLATION}x its size in all, at most {MAX_CHUNK_BYTES} bytes per \
                 chunk); refusing a possible decompression bomb",
                self.file_size
            )));
        }
        if !matches!(header.compression.as_str(), "" | "zstd" | "lz4") {
            return Err(ReadError(format!(
                "{path}: unknown chunk compression {}",
                py_str_repr(&header.compression)
            )));
        }
        self.left -= n;
        Ok(())
    }
}

/// Chunks declaring at most this many bytes are inflated into a buffer of their declared size;
/// larger ones into a buffer that grows with what they really inflate to.
const BULK: usize = 64 << 20;

thread_local! {
    /// A zstd context per thread, reused across chunks.
    static ZSTD: RefCell<Option<zstd::bulk::Decompressor<'static>>> = const { RefCell::new(None) };
}

/// The records of an admitted chunk: `data` itself when uncompressed, else decompressed (at
/// most one byte beyond the declared size), CRC-checked. An error is the damage, worded for
/// "incomplete or damaged record: ...".
pub(crate) fn inflate<'a>(header: &ChunkHeader, data: &'a [u8]) -> Result<Cow<'a, [u8]>, String> {
    let n = header.uncompressed_size;
    // one byte more than declared tells a lying header
    let capacity = usize::try_from(n).unwrap_or(usize::MAX).saturating_add(1);
    let records: Cow<'a, [u8]> = match header.compression.as_str() {
        "" => Cow::Borrowed(data),
        "zstd" if capacity <= BULK => {
            let mut out = Vec::with_capacity(capacity);
            let result = ZSTD.with(|cell| {
                let mut slot = cell.borrow_mut();
                if slot.is_none() {
                    *slot = Some(zstd::bulk::Decompressor::new()?);
                }
                slot.as_mut()
                    .expect("just created")
                    .decompress_to_buffer(data, &mut out)
            });
            match result {
                Ok(_) => {}
                Err(e) if e.to_string().contains("Destination buffer is too small") => {
                    return Err(too_big(n));
                }
                Err(e) => return Err(format!("zstd cannot decompress it: {e}")),
            }
            Cow::Owned(out)
        }
        "zstd" => {
            // a large declared size: the buffer grows with what really comes out
            let mut out = Vec::with_capacity(BULK);
            let decoder = zstd::stream::read::Decoder::new(data)
                .map_err(|e| format!("zstd cannot decompress it: {e}"))?;
            decoder
                .take(n.saturating_add(1))
                .read_to_end(&mut out)
                .map_err(|e| format!("zstd cannot decompress it: {e}"))?;
            Cow::Owned(out)
        }
        "lz4" => {
            let mut out = Vec::with_capacity(capacity.min(BULK));
            let decoder =
                lz4::Decoder::new(data).map_err(|e| format!("lz4 cannot decompress it: {e}"))?;
            decoder
                .take(n.saturating_add(1))
                .read_to_end(&mut out)
                .map_err(|e| format!("lz4 cannot decompress it: {e}"))?;
            Cow::Owned(out)
        }
        other => return Err(format!("unknown chunk compression {}", py_str_repr(other))),
    };
    if records.len() as u64 > n {
        return Err(too_big(n));
    }
    if records.len() as u64 != n {
        return Err(format!(
            "it inflates to {} bytes, its header says {n}",
            records.len()
        ));
    }
    if header.uncompressed_crc != 0 {
        let calculated = crc32fast::hash(&records);
        if calculated != header.uncompressed_crc {
            return Err(format!(
                "its records' CRC is {calculated}, its header says {}",
                header.uncompressed_crc
            ));
        }
    }
    Ok(records)
}

fn too_big(n: u64) -> String {
    format!("it inflates to more than {n} bytes, its header says {n}")
}

/// The records of an admitted chunk, inflated as a stream.
fn stream<'a>(header: &ChunkHeader, data: &'a [u8]) -> Result<Box<dyn Read + 'a>, String> {
    Ok(match header.compression.as_str() {
        "" => Box::new(data),
        "zstd" => Box::new(
            zstd::stream::read::Decoder::new(data)
                .map_err(|e| format!("zstd cannot decompress it: {e}"))?,
        ),
        "lz4" => {
            Box::new(lz4::Decoder::new(data).map_err(|e| format!("lz4 cannot decompress it: {e}"))?)
        }
        other => return Err(format!("unknown chunk compression {}", py_str_repr(other))),
    })
}

/// Check an admitted chunk without keeping its records: inflated block by block (1 MiB at a
/// time, whatever its size), its length and CRC compared with its header. The error is worded
/// as [`inflate`]'s.
pub(crate) fn check(header: &ChunkHeader, data: &[u8]) -> Result<(), String> {
    let n = header.uncompressed_size;
    let mut reader = stream(header, data)?;
    let mut buf = vec![0u8; 1 << 20];
    let mut hasher = crc32fast::Hasher::new();
    let mut got = 0u64;
    loop {
        let k = reader
            .read(&mut buf)
            .map_err(|e| format!("{} cannot decompress it: {e}", header.compression))?;
        if k == 0 {
            break;
        }
        got += k as u64;
        if got > n {
            return Err(too_big(n));
        }
        hasher.update(&buf[..k]);
    }
    if got != n {
        return Err(format!("it inflates to {got} bytes, its header says {n}"));
    }
    let calculated = hasher.finalize();
    if header.uncompressed_crc != 0 && calculated != header.uncompressed_crc {
        return Err(format!(
            "its records' CRC is {calculated}, its header says {}",
            header.uncompressed_crc
        ));
    }
    Ok(())
}

/// The messages of an admitted (and checked) chunk on the channels `keep` accepts, inflated as
/// a stream: `each(channel, log time, payload)`; the payloads of the others are never held
/// (memory: the largest message kept, not the chunk). Stops at the first error, or when
/// `each` returns false.
pub(crate) fn messages(
    header: &ChunkHeader,
    data: &[u8],
    keep: impl Fn(u16) -> bool,
    mut each: impl FnMut(u16, u64, &[u8]) -> bool,
) -> Result<(), String> {
    let mut left = header.uncompressed_size;
    let mut reader = stream(header, data)?.take(left);
    let mut head = [0u8; 9];
    let mut body = Vec::new();
    let cut = |e: std::io::Error| format!("a record is cut: {e}");
    while left >= 9 {
        reader.read_exact(&mut head).map_err(cut)?;
        left -= 9;
        let len = u64::from_le_bytes(head[1..9].try_into().unwrap_or_default());
        if len > left {
            return Err(format!("a record of {len} bytes runs past its chunk"));
        }
        left -= len;
        let mut rest = (&mut reader).take(len);
        if head[0] == crate::records::op::MESSAGE && len >= 22 {
            let mut mh = [0u8; 22];
            rest.read_exact(&mut mh).map_err(cut)?;
            let channel = u16::from_le_bytes([mh[0], mh[1]]);
            if keep(channel) {
                body.clear();
                rest.read_to_end(&mut body).map_err(cut)?;
                let t = u64::from_le_bytes(mh[6..14].try_into().unwrap_or_default());
                if !each(channel, t, &body) {
                    return Ok(());
                }
                continue;
            }
        }
        std::io::copy(&mut rest, &mut std::io::sink()).map_err(cut)?;
    }
    Ok(())
}
