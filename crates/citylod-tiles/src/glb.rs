//! The GLB container (glTF 2.0 §4.4): a 12-byte header, a JSON chunk padded with spaces so that it ends on an
//! 8-byte boundary of the file (EXT_structural_metadata asks for it: the BIN chunk's data then starts on one
//! too, so a client can view a FLOAT64 or INT64 column in place), and a BIN chunk padded with zeros to 4 bytes.
//! Also the binary buffer builder that keeps every buffer view 8-byte aligned within the buffer.

const MAGIC: u32 = 0x4654_6C67; // "glTF"
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// Builds a binary buffer whose pieces all start at multiples of 8 bytes.
#[derive(Default)]
pub(crate) struct BinBuilder {
    pub bytes: Vec<u8>,
}

impl BinBuilder {
    /// Appends `data` at the next 8-byte boundary and returns its offset.
    pub fn push(&mut self, data: &[u8]) -> usize {
        self.reserve(data.len());
        let off = self.bytes.len() - data.len();
        self.bytes[off..].copy_from_slice(data);
        off
    }

    /// Reserves `len` zero bytes at the next 8-byte boundary and returns their offset.
    pub fn reserve(&mut self, len: usize) -> usize {
        self.bytes.resize(self.bytes.len().next_multiple_of(8), 0);
        let off = self.bytes.len();
        self.bytes.resize(off + len, 0);
        off
    }

    /// Length padded to 8 bytes.
    pub fn padded_len(&self) -> usize {
        self.bytes.len().next_multiple_of(8)
    }
}

/// The little-endian u32 at byte `i` of `b`; `None` past its end (the headers of glb and the 3D Tiles 1.0 formats).
pub(crate) fn le_u32(b: &[u8], i: usize) -> Option<u32> {
    b.get(i..i.checked_add(4)?)
        .map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

/// Assembles a glb from its JSON text and binary chunk (which may be empty: then no BIN chunk).
pub(crate) fn write_glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    // The JSON data starts at byte 20 of the file; it ends on an 8-byte boundary, so its padded length is 4
    // more than a multiple of 8, and the BIN data (8 bytes after it) starts on one too.
    let json_len = (json.len() + 4).next_multiple_of(8) - 4;
    let bin_len = bin.len().next_multiple_of(4);
    let total = 12 + 8 + json_len + if bin.is_empty() { 0 } else { 8 + bin_len };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(&MAGIC.to_le_bytes());
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_len as u32).to_le_bytes());
    out.extend_from_slice(&CHUNK_JSON.to_le_bytes());
    out.extend_from_slice(json);
    out.resize(20 + json_len, b' ');
    if !bin.is_empty() {
        out.extend_from_slice(&(bin_len as u32).to_le_bytes());
        out.extend_from_slice(&CHUNK_BIN.to_le_bytes());
        out.extend_from_slice(bin);
        out.resize(total, 0);
    }
    debug_assert_eq!(out.len(), total);
    out
}

/// Splits a glb into its JSON chunk and BIN chunk (empty when absent).
pub(crate) fn parse_glb(b: &[u8]) -> Result<(&[u8], &[u8]), String> {
    let u32_at = |i: usize| le_u32(b, i).ok_or_else(|| "truncated".to_string());
    if u32_at(0)? != MAGIC {
        return Err("not a glb (bad magic)".into());
    }
    if u32_at(4)? != 2 {
        return Err(format!("glb version {} is not 2", u32_at(4)?));
    }
    // The header's length is the whole file's (glTF 2.0 §4.4.3.1): a file shorter than that was cut off.
    let total = u32_at(8)? as usize;
    if total > b.len() {
        return Err(format!(
            "truncated: the header gives a length of {total} bytes, the file has {}",
            b.len()
        ));
    }
    if total < 20 {
        return Err(format!(
            "the header gives a length of {total} bytes, less than a header and one chunk"
        ));
    }
    let b = &b[..total];
    let mut pos = 12;
    let (mut json, mut bin): (Option<&[u8]>, &[u8]) = (None, &[]);
    while pos + 8 <= total {
        let len = u32_at(pos)? as usize;
        let ty = u32_at(pos + 4)?;
        let data = b
            .get(pos + 8..pos + 8 + len)
            .ok_or_else(|| {
                format!(
                    "chunk at byte {pos} claims {len} bytes, past the length of {total} the header gives"
                )
            })?;
        match ty {
            CHUNK_JSON if json.is_none() => json = Some(data),
            CHUNK_BIN if bin.is_empty() => bin = data,
            _ => {}
        }
        pos += 8 + len;
    }
    Ok((json.ok_or("no JSON chunk")?, bin))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glb_chunks_round_trip_and_are_padded() {
        let glb = write_glb(b"{\"a\":1}", &[1, 2, 3]);
        assert_eq!(glb.len() % 4, 0);
        let (j, bin) = parse_glb(&glb).unwrap();
        assert_eq!(j, b"{\"a\":1}     ");
        assert_eq!(bin, &[1, 2, 3, 0]);
        for n in 0..24 {
            let json = format!("[{}]", " ".repeat(n));
            let glb = write_glb(json.as_bytes(), &[7; 8]);
            let (j, bin) = parse_glb(&glb).unwrap();
            assert_eq!(std::str::from_utf8(j).unwrap().trim_end(), json);
            // The JSON chunk ends on an 8-byte boundary of the file, so the BIN data starts on one.
            let bin_at = bin.as_ptr() as usize - glb.as_ptr() as usize;
            assert_eq!((20 + j.len()) % 8, 0, "json of {} bytes", json.len());
            assert_eq!(bin_at % 8, 0, "json of {} bytes", json.len());
        }
        assert!(parse_glb(b"glTF").is_err());
        assert!(parse_glb(&glb[..20]).is_err());
    }

    #[test]
    fn a_glb_shorter_than_its_header_says_is_truncated() {
        let glb = write_glb(b"{\"a\":1}", &[1, 2, 3, 4, 5, 6, 7, 8]);
        assert!(parse_glb(&glb).is_ok());
        // Cut anywhere, including inside the BIN chunk where a clamped length would still find the JSON.
        for cut in 12..glb.len() {
            let e = parse_glb(&glb[..cut]).unwrap_err();
            assert!(e.contains("truncated"), "cut at {cut}: {e}");
        }
        // The header lying about a larger length than the file has.
        let mut lie = glb.clone();
        lie[8..12].copy_from_slice(&(glb.len() as u32 + 100).to_le_bytes());
        let e = parse_glb(&lie).unwrap_err();
        assert!(
            e.contains(&format!("length of {} bytes", glb.len() + 100)),
            "{e}"
        );
        // A chunk running past the header's length (the file itself longer) is an error too.
        let mut long = glb.clone();
        long.extend_from_slice(&[0; 16]);
        long[8..12].copy_from_slice(&(glb.len() as u32 - 4).to_le_bytes());
        assert!(parse_glb(&long).unwrap_err().contains("past the length"));
    }

    #[test]
    fn bin_builder_aligns_to_8() {
        let mut b = BinBuilder::default();
        assert_eq!(b.push(&[1, 2, 3]), 0);
        assert_eq!(b.push(&[4]), 8);
        assert_eq!(b.reserve(2), 16);
        assert_eq!(b.padded_len(), 24);
    }
}
