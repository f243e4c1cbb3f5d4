//! Chunk inflation within a decompression-bomb budget (as `lfd.io.mcapfile._inflate`).

use std::io::Read;

use mcap::records::ChunkHeader;

use crate::{py_str_repr, ReadError, MAX_CHUNK_BYTES, MAX_INFLATION};

/// Why a chunk could not be inflated.
pub(crate) enum InflateError {
    /// The file cannot be read (a bomb, an unknown compression): the whole read fails.
    Fatal(ReadError),
    /// The chunk is damaged: the pass ends here, keeping what came before.
    Damaged(String),
}

/// The remaining inflation budget of one file.
pub(crate) struct Budget {
    pub left: u64,
    pub file_size: u64,
    /// A zstd context reused across chunks.
    zstd: Option<zstd::bulk::Decompressor<'static>>,
}

impl Budget {
    pub fn new(file_size: u64) -> Self {
        Self {
            left: crate::inflate_limit(file_size),
            file_size,
            zstd: None,
        }
    }

    /// Check `header` against the budget (before anything is decompressed), inflate `data`
    /// into `out` (cleared first; decompression stops one byte beyond the declared size),
    /// and validate its CRC. Returns the uncompressed records: `data` itself for an
    /// uncompressed chunk, else `out`.
    pub fn inflate<'a>(
        &mut self,
        path: &str,
        header: &ChunkHeader,
        data: &'a [u8],
        out: &'a mut Vec<u8>,
    ) -> Result<&'a [u8], InflateError> {
        let n = header.uncompressed_size;
        let limit = self.left.min(MAX_CHUNK_BYTES);
        if n > limit {
            return Err(InflateError::Fatal(ReadError(format!(
                "{path}: a chunk of {} bytes declares {n} uncompressed bytes, more than the \
                 {limit} bytes this {}-byte file may still inflate to ({MAX_INFLATION}x its \
                 size in all, at most {MAX_CHUNK_BYTES} bytes per chunk); refusing a possible \
                 decompression bomb",
                data.len(),
                self.file_size
            ))));
        }
        let records: &[u8] = match header.compression.as_str() {
            "" => data,
            "zstd" => {
                let zstd_error =
                    |e: std::io::Error| InflateError::Damaged(format!("ZstdError: {e}"));
                if self.zstd.is_none() {
                    self.zstd = Some(zstd::bulk::Decompressor::new().map_err(zstd_error)?);
                }
                let dctx = self.zstd.as_mut().expect("just created");
                out.clear();
                // one byte more than declared tells a lying header
                out.reserve_exact(usize::try_from(n).unwrap_or(usize::MAX).saturating_add(1));
                match dctx.decompress_to_buffer(data, out) {
                    Ok(_) => {}
                    Err(e) if e.to_string().contains("Destination buffer is too small") => {
                        return Err(too_big(n));
                    }
                    Err(e) => return Err(zstd_error(e)),
                }
                out
            }
            "lz4" => {
                out.clear();
                let decoder = lz4::Decoder::new(data)
                    .map_err(|e| InflateError::Damaged(format!("LZ4FrameError: {e}")))?;
                read_bounded(decoder, n, out)
                    .map_err(|e| InflateError::Damaged(format!("LZ4FrameError: {e}")))?;
                out
            }
            other => {
                return Err(InflateError::Fatal(ReadError(format!(
                    "{path}: unknown chunk compression {}",
                    py_str_repr(other)
                ))))
            }
        };
        if records.len() as u64 > n {
            return Err(too_big(n));
        }
        if records.len() as u64 != n {
            return Err(InflateError::Damaged(format!(
                "ValueError: a chunk inflates to {} bytes, its header says {n}",
                records.len()
            )));
        }
        if header.uncompressed_crc != 0 {
            let calculated = crc32fast::hash(records);
            if calculated != header.uncompressed_crc {
                return Err(InflateError::Damaged(format!(
                    "CRCValidationError: crc validation failed in Chunk, expected: {}, \
                     calculated: {calculated}",
                    header.uncompressed_crc
                )));
            }
        }
        self.left -= n;
        Ok(records)
    }
}

/// Read at most `n + 1` bytes of `reader` into `out` (one byte more than declared tells a
/// lying header).
fn read_bounded(reader: impl Read, n: u64, out: &mut Vec<u8>) -> std::io::Result<()> {
    out.reserve_exact(usize::try_from(n).unwrap_or(usize::MAX).saturating_add(1));
    reader.take(n.saturating_add(1)).read_to_end(out)?;
    Ok(())
}

fn too_big(n: u64) -> InflateError {
    InflateError::Damaged(format!(
        "ValueError: a chunk inflates to more than {n} bytes, its header says {n}"
    ))
}
