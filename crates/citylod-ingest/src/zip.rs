//! Compressed inputs: gzip ([`gunzipped`]), and members of a ZIP archive (PKWARE's APPNOTE: the end of central directory record, its ZIP64 form, the
//! central directory, local headers), as File Geodatabases are downloaded (`Buildings.gdb.zip`). Members stored or
//! deflated (flate2), each checked against its CRC-32; other methods and encrypted members are refused by name.
//! Only the member asked for is inflated, so a large archive costs no more memory than its largest table.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

/// The signature a ZIP archive's first member starts with (its local file header): what the archive begins with.
pub(crate) const MEMBER_MAGIC: &[u8; 4] = b"PK\x03\x04";

/// A file starting with a ZIP member's signature, whatever its name.
pub(crate) fn begins_as_zip(path: &Path) -> bool {
    let mut head = [0u8; 4];
    File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok()
        && &head == MEMBER_MAGIC
}

/// `bytes` inflated when they are gzip-compressed (by their magic number, whatever the name says), up to `max` + 1
/// bytes (the caller judges a text over `max`); `None` when they are not.
pub(crate) fn gunzipped(bytes: &[u8], max: u64) -> Result<Option<Vec<u8>>, String> {
    if !bytes.starts_with(&[0x1f, 0x8b]) {
        return Ok(None);
    }
    let mut out = Vec::new();
    flate2::read::MultiGzDecoder::new(bytes)
        .take(max + 1)
        .read_to_end(&mut out)
        .map_err(|e| format!("cannot decompress (gzip): {e}"))?;
    Ok(Some(out))
}

/// One member of the archive, as its central directory lists it.
#[derive(Debug, Clone)]
pub(crate) struct Member {
    pub name: String,
    method: u16,
    flags: u16,
    crc: u32,
    compressed: u64,
    pub size: u64,
    local_header: u64,
}

/// An open archive: its file and its members.
pub(crate) struct Archive {
    file: std::sync::Mutex<File>,
    pub members: Vec<Member>,
}

/// Longest member inflated: a table claiming more is refused rather than filling the memory.
const MAX_MEMBER_BYTES: u64 = 16 << 30;

fn le16(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([b[at], b[at + 1]])
}
fn le32(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"))
}
fn le64(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes"))
}

impl Archive {
    /// Opens `path` and reads its central directory.
    pub(crate) fn open(path: &Path) -> Result<Archive, String> {
        let mut file = File::open(path).map_err(|e| format!("cannot read it: {e}"))?;
        let len = file
            .metadata()
            .map_err(|e| format!("cannot read it: {e}"))?
            .len();
        // The end of central directory record: 22 bytes and a comment of up to 65,535 at the end of the file.
        let tail_len = len.min(22 + 65_535);
        let mut tail = vec![0u8; tail_len as usize];
        file.seek(SeekFrom::Start(len - tail_len))
            .and_then(|_| file.read_exact(&mut tail))
            .map_err(|e| format!("cannot read it: {e}"))?;
        let Some(eocd) = (0..tail.len().saturating_sub(21))
            .rev()
            .find(|&i| le32(&tail, i) == 0x0605_4b50)
        else {
            // A file that begins with a member's local header is a ZIP archive whose end is gone (a download or copy
            // cut short), not some other file.
            let mut magic = [0u8; 4];
            let begins_as_zip = file
                .seek(SeekFrom::Start(0))
                .and_then(|_| file.read_exact(&mut magic))
                .is_ok()
                && &magic == MEMBER_MAGIC;
            return Err(if begins_as_zip {
                "a ZIP archive cut short or damaged: it begins as one, but the central directory at its end is \
                 missing (was a download or copy interrupted?)"
                    .into()
            } else {
                "not a ZIP archive (no end of central directory record)".into()
            });
        };
        let mut entries = u64::from(le16(&tail, eocd + 10));
        let mut cd_size = u64::from(le32(&tail, eocd + 12));
        let mut cd_offset = u64::from(le32(&tail, eocd + 16));
        // ZIP64: a locator just before the record points to a record with 64-bit counts.
        if eocd >= 20 && le32(&tail, eocd - 20) == 0x0706_4b50 {
            let at = le64(&tail, eocd - 12);
            let mut rec = [0u8; 56];
            file.seek(SeekFrom::Start(at))
                .and_then(|_| file.read_exact(&mut rec))
                .map_err(|e| format!("its ZIP64 end of central directory cannot be read: {e}"))?;
            if le32(&rec, 0) != 0x0606_4b50 {
                return Err(
                    "its ZIP64 end of central directory record is not where its locator says"
                        .into(),
                );
            }
            entries = le64(&rec, 32);
            cd_size = le64(&rec, 40);
            cd_offset = le64(&rec, 48);
        }
        if cd_offset.checked_add(cd_size).is_none_or(|end| end > len) || cd_size > 1 << 32 {
            return Err(format!(
                "its central directory ({cd_size} bytes at {cd_offset}) lies outside the file ({len} bytes)"
            ));
        }
        let mut cd = vec![0u8; cd_size as usize];
        file.seek(SeekFrom::Start(cd_offset))
            .and_then(|_| file.read_exact(&mut cd))
            .map_err(|e| format!("its central directory cannot be read: {e}"))?;
        let mut members = Vec::new();
        let mut at = 0usize;
        while at + 46 <= cd.len() && le32(&cd, at) == 0x0201_4b50 {
            let flags = le16(&cd, at + 8);
            let method = le16(&cd, at + 10);
            let crc = le32(&cd, at + 16);
            let mut compressed = u64::from(le32(&cd, at + 20));
            let mut size = u64::from(le32(&cd, at + 24));
            let (name_len, extra_len, comment_len) = (
                le16(&cd, at + 28) as usize,
                le16(&cd, at + 30) as usize,
                le16(&cd, at + 32) as usize,
            );
            let mut local_header = u64::from(le32(&cd, at + 42));
            let end = at + 46 + name_len + extra_len + comment_len;
            if end > cd.len() {
                return Err("its central directory is cut short".into());
            }
            let raw_name = &cd[at + 46..at + 46 + name_len];
            // Bit 11: the name is UTF-8; else IBM code page 437, which for the ASCII names of a geodatabase is the same.
            let name = String::from_utf8_lossy(raw_name).replace('\\', "/");
            // The ZIP64 extra field holds the sizes and offset whose 32-bit fields are all ones, in this order.
            let mut extra = &cd[at + 46 + name_len..at + 46 + name_len + extra_len];
            while extra.len() >= 4 {
                let (id, n) = (le16(extra, 0), le16(extra, 2) as usize);
                let body = &extra[4..(4 + n).min(extra.len())];
                if id == 0x0001 {
                    let mut k = 0;
                    let mut next = |v: &mut u64| {
                        if *v == 0xffff_ffff && k + 8 <= body.len() {
                            *v = le64(body, k);
                            k += 8;
                        }
                    };
                    next(&mut size);
                    next(&mut compressed);
                    next(&mut local_header);
                }
                extra = &extra[(4 + n).min(extra.len())..];
            }
            members.push(Member {
                name,
                method,
                flags,
                crc,
                compressed,
                size,
                local_header,
            });
            at = end;
        }
        if (members.len() as u64) < entries.min(u64::from(u32::MAX)) && members.len() < 65_535 {
            return Err(format!(
                "its central directory lists {} of the {entries} members its end record counts",
                members.len()
            ));
        }
        Ok(Archive {
            file: std::sync::Mutex::new(file),
            members,
        })
    }

    /// The bytes of `member`, inflated and checked against its CRC-32; or only its first `limit` bytes (not checked).
    pub(crate) fn read(&self, member: &Member, limit: Option<u64>) -> Result<Vec<u8>, String> {
        let what = |d: String| format!("member {}: {d}", member.name);
        if member.flags & 1 != 0 {
            return Err(what(
                "it is encrypted; unzip it with its password first".into(),
            ));
        }
        if member.size > MAX_MEMBER_BYTES {
            return Err(what(format!(
                "{} bytes, more than this reader inflates ({MAX_MEMBER_BYTES}); unzip the archive first",
                member.size
            )));
        }
        let mut file = self.file.lock().unwrap_or_else(|e| e.into_inner());
        let mut head = [0u8; 30];
        file.seek(SeekFrom::Start(member.local_header))
            .and_then(|_| file.read_exact(&mut head))
            .map_err(|e| what(format!("its local header cannot be read: {e}")))?;
        if le32(&head, 0) != 0x0403_4b50 {
            return Err(what(
                "its local header is not where the central directory says".into(),
            ));
        }
        let skip = u64::from(le16(&head, 26)) + u64::from(le16(&head, 28));
        file.seek(SeekFrom::Current(skip as i64))
            .map_err(|e| what(format!("cannot be read: {e}")))?;
        let raw = (&mut *file).take(member.compressed);
        let prefix = limit.filter(|&n| n < member.size);
        // The size is the archive's claim: reserve at most 64 MiB on its word (a damaged header may claim 16 GiB,
        // and a strict-overcommit system would refuse that up front); reading grows the buffer past it as needed.
        let mut out = Vec::with_capacity(prefix.unwrap_or(member.size).min(1 << 26) as usize);
        let limit = prefix.unwrap_or(member.size + 1);
        let read = match member.method {
            0 => raw.take(limit).read_to_end(&mut out),
            8 => flate2::read::DeflateDecoder::new(raw)
                .take(limit)
                .read_to_end(&mut out),
            m => {
                let name = match m {
                    9 => "Deflate64",
                    12 => "bzip2",
                    14 => "LZMA",
                    93 => "Zstandard",
                    95 => "XZ",
                    _ => "an unknown method",
                };
                return Err(what(format!(
                    "compressed with {name} (method {m}); this reader inflates stored and deflated members: unzip \
                     the archive first"
                )));
            }
        };
        read.map_err(|e| what(format!("cannot be inflated: {e}")))?;
        if prefix.is_some() {
            return Ok(out);
        }
        if out.len() as u64 != member.size {
            return Err(what(format!(
                "inflates to {} bytes where the archive says {}",
                out.len(),
                member.size
            )));
        }
        let mut crc = flate2::Crc::new();
        crc.update(&out);
        if crc.sum() != member.crc {
            return Err(what(
                "its CRC-32 does not match: the archive is damaged".into(),
            ));
        }
        Ok(out)
    }
}
