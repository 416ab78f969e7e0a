//! ZIP archives for tests (PKWARE's APPNOTE: local headers, the central directory, its end record), stored or
//! deflated, with where each record starts so that a test can damage them.

use std::io::Write;

/// An archive and where its records start.
pub struct Zip {
    pub bytes: Vec<u8>,
    /// Each member's local header.
    pub locals: Vec<usize>,
    /// Each member's central directory entry.
    pub central: Vec<usize>,
    /// The end of central directory record.
    pub eocd: usize,
}

/// The archive of `entries` (name, contents), each deflated or stored.
pub fn zip(entries: &[(String, Vec<u8>)], deflate: bool) -> Zip {
    let mut b = Vec::new();
    let mut locals = Vec::new();
    let mut cd = Vec::new();
    let mut cd_starts = Vec::new();
    for (name, data) in entries {
        let mut crc = flate2::Crc::new();
        crc.update(data);
        let crc = crc.sum();
        let (method, body) = if deflate {
            let mut e = flate2::write::DeflateEncoder::new(Vec::new(), flate2::Compression::fast());
            e.write_all(data).unwrap();
            (8u16, e.finish().unwrap())
        } else {
            (0u16, data.clone())
        };
        let at = b.len();
        locals.push(at);
        let head = |sig: u32, central: bool| {
            let mut h = sig.to_le_bytes().to_vec();
            if central {
                h.extend(20u16.to_le_bytes());
            }
            h.extend(20u16.to_le_bytes());
            h.extend(0u16.to_le_bytes());
            h.extend(method.to_le_bytes());
            h.extend([0u8; 4]);
            h.extend(crc.to_le_bytes());
            h.extend((body.len() as u32).to_le_bytes());
            h.extend((data.len() as u32).to_le_bytes());
            h.extend((name.len() as u16).to_le_bytes());
            h.extend(0u16.to_le_bytes());
            if central {
                // Comment length, disk, internal and external attributes.
                h.extend([0u8; 6]);
                h.extend(0u32.to_le_bytes());
                h.extend((at as u32).to_le_bytes());
            }
            h.extend_from_slice(name.as_bytes());
            h
        };
        b.extend(head(0x0403_4b50, false));
        b.extend_from_slice(&body);
        cd_starts.push(cd.len());
        cd.extend(head(0x0201_4b50, true));
    }
    let cd_at = b.len();
    let central = cd_starts.iter().map(|s| s + cd_at).collect();
    b.extend_from_slice(&cd);
    let eocd = b.len();
    b.extend(0x0605_4b50u32.to_le_bytes());
    b.extend([0u8; 4]);
    b.extend((entries.len() as u16).to_le_bytes());
    b.extend((entries.len() as u16).to_le_bytes());
    b.extend((cd.len() as u32).to_le_bytes());
    b.extend((cd_at as u32).to_le_bytes());
    b.extend(0u16.to_le_bytes());
    Zip {
        bytes: b,
        locals,
        central,
        eocd,
    }
}
