//! The fixed 22-byte header in front of every payload.

use super::{DecodeError, HEADER_LEN, MAGIC, SUPPORTED_VERSIONS};

/// The parsed header of a model blob (see the layout table in [`crate::model`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    pub version: u16,
    pub d: u16,
    pub p: u16,
    pub k: u16,
    pub lift_terms: u16,
    pub payload_len: u32,
    pub crc: u32,
}

fn u16_at(b: &[u8], at: usize) -> Option<u16> {
    let s = b.get(at..at.checked_add(2)?)?;
    Some(u16::from_le_bytes([*s.first()?, *s.get(1)?]))
}

fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    let s = b.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([*s.first()?, *s.get(1)?, *s.get(2)?, *s.get(3)?]))
}

impl Header {
    /// Parses and checks magic, version and the blob's total length (not the CRC).
    /// Returns the header and the payload slice.
    pub fn parse(blob: &[u8]) -> Result<(Self, &[u8]), DecodeError> {
        let truncated = DecodeError::Truncated { needed: HEADER_LEN, got: blob.len() };
        let magic = blob.get(..4).ok_or(truncated)?;
        if magic != MAGIC {
            let mut found = [0u8; 4];
            found.copy_from_slice(magic);
            return Err(DecodeError::BadMagic { found });
        }
        let version = u16_at(blob, 4).ok_or(truncated)?;
        if !SUPPORTED_VERSIONS.contains(&version) {
            return Err(DecodeError::UnsupportedVersion { found: version, supported: SUPPORTED_VERSIONS });
        }
        let field = |at| u16_at(blob, at).ok_or(truncated);
        let (d, p, k, lift_terms) = (field(6)?, field(8)?, field(10)?, field(12)?);
        let payload_len = u32_at(blob, 14).ok_or(truncated)?;
        let crc = u32_at(blob, 18).ok_or(truncated)?;
        let total = usize::try_from(payload_len)
            .ok()
            .and_then(|n| n.checked_add(HEADER_LEN))
            .ok_or(DecodeError::Truncated { needed: usize::MAX, got: blob.len() })?;
        if blob.len() < total {
            return Err(DecodeError::Truncated { needed: total, got: blob.len() });
        }
        if blob.len() > total {
            return Err(DecodeError::TrailingBytes { expected: total, got: blob.len() });
        }
        let payload = blob.get(HEADER_LEN..).ok_or(truncated)?;
        Ok((Self { version, d, p, k, lift_terms, payload_len, crc }, payload))
    }

    /// The header bytes.
    pub fn to_bytes(&self) -> [u8; HEADER_LEN] {
        let mut out = [0u8; HEADER_LEN];
        let fields: [&[u8]; 8] = [
            &MAGIC,
            &self.version.to_le_bytes(),
            &self.d.to_le_bytes(),
            &self.p.to_le_bytes(),
            &self.k.to_le_bytes(),
            &self.lift_terms.to_le_bytes(),
            &self.payload_len.to_le_bytes(),
            &self.crc.to_le_bytes(),
        ];
        let mut dst = out.iter_mut();
        for byte in fields.into_iter().flatten() {
            if let Some(d) = dst.next() {
                *d = *byte;
            }
        }
        out
    }
}
