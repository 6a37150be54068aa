//! The postcard payload, the borrowed model view and the allocation-free encoder.

use serde::de::{Deserializer, Visitor};
use serde::ser::{SerializeSeq, Serializer};
use serde::{Deserialize, Serialize};

use super::{CRC32, DecodeError, EncodeError, FORMAT_VERSION, HEADER_LEN, Header, Scalars, check_scalars, lift_terms};
use crate::config::ControllerConfig;

/// A model whose matrices are borrowed `f32` slices (row-major): what an encoder reads.
/// Shapes: `v1` is `p x d`, `lift` is `p x lift_terms(d, lift_order)`, `centres` and
/// `weights` are `k x d`, `affine` is `d x (d+1)` (last column the constant term).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelRef<'a> {
    pub config: ControllerConfig,
    /// Embedding dimension (number of delayed samples).
    pub p: usize,
    /// Delay between embedding components, in samples.
    pub shift: usize,
    /// Sample period of the observable and time step of the RBF map, s.
    pub sample_period: f32,
    pub offset: f32,
    pub scale: f32,
    /// Reduced dimension.
    pub d: usize,
    /// Highest monomial degree of the lift (1 = linear lift, no monomials).
    pub lift_order: usize,
    /// Number of RBF centres.
    pub k: usize,
    pub v1: &'a [f32],
    pub lift: &'a [f32],
    pub centres: &'a [f32],
    pub weights: &'a [f32],
    pub affine: &'a [f32],
}

/// The wire payload; `M` is the matrix representation (borrowed f32s when writing, borrowed
/// bytes when reading). Field order is the format: never reorder within a version.
#[derive(Serialize, Deserialize)]
pub(crate) struct Payload<M> {
    pub config: ControllerConfig,
    pub p: u16,
    pub shift: u16,
    pub sample_period: f32,
    pub offset: f32,
    pub scale: f32,
    pub d: u16,
    pub lift_order: u8,
    pub n_terms: u16,
    pub k: u16,
    pub v1: M,
    pub lift: M,
    pub centres: M,
    pub weights: M,
    pub affine: M,
}

/// Writes an `f32` slice as a postcard byte string of little-endian floats (a sequence of
/// `u8` is byte-identical to `serialize_bytes` in postcard: varint length, then the bytes).
pub(crate) struct F32Out<'a>(pub &'a [f32]);

impl Serialize for F32Out<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let n = self.0.len().saturating_mul(4);
        let mut seq = s.serialize_seq(Some(n))?;
        for x in self.0 {
            for b in x.to_le_bytes() {
                seq.serialize_element(&b)?;
            }
        }
        seq.end()
    }
}

/// Reads a postcard byte string without copying.
pub(crate) struct BytesIn<'a>(pub &'a [u8]);

impl<'de> Deserialize<'de> for BytesIn<'de> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = BytesIn<'de>;
            fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                f.write_str("a byte string of little-endian f32")
            }
            fn visit_borrowed_bytes<E: serde::de::Error>(self, v: &'de [u8]) -> Result<Self::Value, E> {
                Ok(BytesIn(v))
            }
        }
        d.deserialize_bytes(V)
    }
}

/// A validated blob: header and borrowed payload, every check passed.
pub(crate) struct Checked<'a> {
    pub payload: Payload<BytesIn<'a>>,
    pub n_terms: usize,
}

fn shape(what: &'static str, header: usize, payload: usize) -> Result<(), DecodeError> {
    if header == payload { Ok(()) } else { Err(DecodeError::ShapeMismatch { what, header, payload }) }
}

fn finite_bytes(what: &'static str, bytes: &[u8]) -> Result<(), DecodeError> {
    for c in bytes.chunks_exact(4) {
        let mut a = [0u8; 4];
        a.copy_from_slice(c);
        if !f32::from_le_bytes(a).is_finite() {
            return Err(DecodeError::NonFinite { what });
        }
    }
    Ok(())
}

/// Every check of the format, in this order: header (magic, version, length), CRC, the
/// fixed capacities `caps = [p, d, k, lift_terms]`, postcard, header/payload shape
/// agreement, value ranges, finiteness.
pub(crate) fn check(blob: &[u8], caps: [usize; 4]) -> Result<Checked<'_>, DecodeError> {
    let (h, payload_bytes) = Header::parse(blob)?;
    let found = CRC32.checksum(payload_bytes);
    if found != h.crc {
        return Err(DecodeError::Crc { expected: h.crc, found });
    }
    let [max_p, max_d, max_k, max_t] = caps;
    for (what, max, got) in
        [("p", max_p, h.p), ("d", max_d, h.d), ("k", max_k, h.k), ("lift terms", max_t, h.lift_terms)]
    {
        if usize::from(got) > max {
            return Err(DecodeError::Capacity { what, max, got: usize::from(got) });
        }
    }
    let (payload, rest): (Payload<BytesIn<'_>>, _) =
        postcard::take_from_bytes(payload_bytes).map_err(DecodeError::from_postcard)?;
    if !rest.is_empty() {
        return Err(DecodeError::Postcard { reason: "bytes left over after the payload" });
    }
    let (p, d, k) = (usize::from(payload.p), usize::from(payload.d), usize::from(payload.k));
    shape("p", usize::from(h.p), p)?;
    shape("d", usize::from(h.d), d)?;
    shape("k", usize::from(h.k), k)?;
    shape("lift terms", usize::from(h.lift_terms), usize::from(payload.n_terms))?;
    let n_terms =
        lift_terms(d, usize::from(payload.lift_order)).ok_or(DecodeError::Invalid { what: "lift order too high" })?;
    shape("lift terms for d and lift_order", usize::from(h.lift_terms), n_terms)?;
    check_scalars(&Scalars {
        p,
        d,
        shift: usize::from(payload.shift),
        sample_period: payload.sample_period,
        offset: payload.offset,
        scale: payload.scale,
        lift_order: usize::from(payload.lift_order),
    })?;
    // All products below are of u16 values: at most 65535 * 65536 * 4 < 2^35, checked anyway.
    let bytes = |rows: usize, cols: usize| rows.checked_mul(cols).and_then(|n| n.checked_mul(4));
    let too_big = DecodeError::Invalid { what: "matrix size overflows" };
    let matrices: [(&'static str, &[u8], usize); 5] = [
        ("v1 bytes", payload.v1.0, bytes(p, d).ok_or(too_big)?),
        ("lift bytes", payload.lift.0, bytes(p, n_terms).ok_or(too_big)?),
        ("centres bytes", payload.centres.0, bytes(k, d).ok_or(too_big)?),
        ("weights bytes", payload.weights.0, bytes(k, d).ok_or(too_big)?),
        ("affine bytes", payload.affine.0, bytes(d, d + 1).ok_or(too_big)?),
    ];
    for (what, data, expected) in matrices {
        shape(what, expected, data.len())?;
    }
    for (what, data) in [
        ("v1", payload.v1.0),
        ("lift", payload.lift.0),
        ("centres", payload.centres.0),
        ("weights", payload.weights.0),
        ("affine", payload.affine.0),
    ] {
        finite_bytes(what, data)?;
    }
    Ok(Checked { payload, n_terms })
}

fn to_u16(what: &'static str, v: usize) -> Result<u16, EncodeError> {
    u16::try_from(v).map_err(|_| EncodeError::TooLarge { what, got: v })
}

impl ModelRef<'_> {
    /// Number of lift monomials implied by `d` and `lift_order`.
    pub fn lift_terms(&self) -> Option<usize> {
        lift_terms(self.d, self.lift_order)
    }

    /// An upper bound of the encoded size, for sizing the output buffer.
    pub fn encoded_len_bound(&self) -> usize {
        let floats = [self.v1, self.lift, self.centres, self.weights, self.affine]
            .iter()
            .fold(0usize, |acc, m| acc.saturating_add(m.len()));
        // Header, scalars, varints and the config without its gains: < 160 bytes; each gain
        // (index, p, d, h_adc) at most 1 + 3*8 bytes, bounded by 32.
        floats.saturating_mul(4).saturating_add(HEADER_LEN + 160 + crate::config::MAX_GAINS * 32)
    }

    /// Checks the model as the decoder would and writes the blob into `buf`; returns the
    /// number of bytes written.
    pub fn encode_into(&self, buf: &mut [u8]) -> Result<usize, EncodeError> {
        check_scalars(&Scalars {
            p: self.p,
            d: self.d,
            shift: self.shift,
            sample_period: self.sample_period,
            offset: self.offset,
            scale: self.scale,
            lift_order: self.lift_order,
        })?;
        let n_terms = self.lift_terms().ok_or(EncodeError::TooLarge { what: "lift_order", got: self.lift_order })?;
        let (p, d, k) = (self.p, self.d, self.k);
        let len = |rows: usize, cols: usize, what| {
            rows.checked_mul(cols).ok_or(EncodeError::TooLarge { what, got: usize::MAX })
        };
        for (what, m, expected) in [
            ("v1 length", self.v1, len(p, d, "v1")?),
            ("lift length", self.lift, len(p, n_terms, "lift")?),
            ("centres length", self.centres, len(k, d, "centres")?),
            ("weights length", self.weights, len(k, d, "weights")?),
            ("affine length", self.affine, len(d, d + 1, "affine")?),
        ] {
            shape(what, expected, m.len())?;
        }
        for (what, m) in [
            ("v1", self.v1),
            ("lift", self.lift),
            ("centres", self.centres),
            ("weights", self.weights),
            ("affine", self.affine),
        ] {
            if m.iter().any(|x| !x.is_finite()) {
                return Err(DecodeError::NonFinite { what }.into());
            }
        }
        let payload = Payload {
            config: self.config,
            p: to_u16("p", p)?,
            shift: to_u16("shift", self.shift)?,
            sample_period: self.sample_period,
            offset: self.offset,
            scale: self.scale,
            d: to_u16("d", d)?,
            lift_order: u8::try_from(self.lift_order)
                .map_err(|_| EncodeError::TooLarge { what: "lift_order", got: self.lift_order })?,
            n_terms: to_u16("lift terms", n_terms)?,
            k: to_u16("k", k)?,
            v1: F32Out(self.v1),
            lift: F32Out(self.lift),
            centres: F32Out(self.centres),
            weights: F32Out(self.weights),
            affine: F32Out(self.affine),
        };
        let got = buf.len();
        let (head, body) = buf.split_at_mut_checked(HEADER_LEN).ok_or(EncodeError::BufferTooSmall { got })?;
        let used = postcard::to_slice(&payload, body).map_err(|_| EncodeError::BufferTooSmall { got })?.len();
        let written = body.get(..used).ok_or(EncodeError::BufferTooSmall { got })?;
        let header = Header {
            version: FORMAT_VERSION,
            d: payload.d,
            p: payload.p,
            k: payload.k,
            lift_terms: payload.n_terms,
            payload_len: u32::try_from(used)
                .map_err(|_| EncodeError::TooLarge { what: "payload length", got: used })?,
            crc: CRC32.checksum(written),
        };
        head.copy_from_slice(&header.to_bytes());
        Ok(HEADER_LEN + used)
    }
}
