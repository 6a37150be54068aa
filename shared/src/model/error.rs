//! Errors of the model format: small `Copy` values naming what is wrong.

use core::fmt;

/// Why a blob was rejected. Every check of [`crate::model::Model::decode_into`] has a variant;
/// `what` names the field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// The blob does not start with `b"SSMR"`.
    BadMagic { found: [u8; 4] },
    /// The header's format version is not one this reader accepts.
    UnsupportedVersion { found: u16, supported: &'static [u16] },
    /// The blob is shorter than the header, or than header + declared payload.
    Truncated { needed: usize, got: usize },
    /// The blob is longer than header + declared payload.
    TrailingBytes { expected: usize, got: usize },
    /// The payload's CRC-32 differs from the one in the header.
    Crc { expected: u32, found: u32 },
    /// A dimension or matrix length in the payload disagrees with the header (or with the
    /// length the dimensions imply).
    ShapeMismatch { what: &'static str, header: usize, payload: usize },
    /// A dimension exceeds the decoder's fixed capacity.
    Capacity { what: &'static str, max: usize, got: usize },
    /// A number is NaN or infinite.
    NonFinite { what: &'static str },
    /// A value is outside its allowed range (zero scale, zero shift, d > p, ...).
    Invalid { what: &'static str },
    /// postcard could not decode the payload.
    Postcard { reason: &'static str },
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::BadMagic { found } => write!(f, "bad magic {found:02x?}, expected \"SSMR\""),
            Self::UnsupportedVersion { found, supported } => {
                write!(
                    f,
                    "format version {found} not supported (this reader accepts {supported:?}); re-export the model with this version"
                )
            }
            Self::Truncated { needed, got } => write!(f, "blob truncated: need {needed} bytes, got {got}"),
            Self::TrailingBytes { expected, got } => {
                write!(f, "blob has trailing bytes: expected {expected} bytes, got {got}")
            }
            Self::Crc { expected, found } => {
                write!(f, "payload CRC-32 {found:#010x} differs from header {expected:#010x}")
            }
            Self::ShapeMismatch { what, header, payload } => {
                write!(f, "shape mismatch in {what}: header says {header}, payload has {payload}")
            }
            Self::Capacity { what, max, got } => {
                write!(f, "{what} = {got} exceeds this build's capacity {max}")
            }
            Self::NonFinite { what } => write!(f, "{what} contains a NaN or infinity"),
            Self::Invalid { what } => write!(f, "invalid model: {what}"),
            Self::Postcard { reason } => write!(f, "payload does not decode: {reason}"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for DecodeError {}

impl DecodeError {
    pub(crate) fn from_postcard(e: postcard::Error) -> Self {
        use postcard::Error as E;
        let reason = match e {
            E::DeserializeUnexpectedEnd => "unexpected end of payload",
            E::DeserializeBadVarint => "bad varint",
            E::DeserializeBadBool => "bad bool",
            E::DeserializeBadOption => "bad option tag",
            E::DeserializeBadEnum => "bad enum tag",
            E::DeserializeBadUtf8 => "bad utf-8",
            E::DeserializeBadChar => "bad char",
            E::DeserializeBadEncoding => "bad encoding",
            _ => "other postcard error",
        };
        Self::Postcard { reason }
    }
}

/// Why a model could not be encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncodeError {
    /// The model itself is inconsistent: the same check the decoder would fail.
    Invalid(DecodeError),
    /// A dimension does not fit the header's u16 (or the payload length its u32).
    TooLarge { what: &'static str, got: usize },
    /// The output buffer is too small for the blob.
    BufferTooSmall { got: usize },
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Invalid(e) => write!(f, "model is not encodable: {e}"),
            Self::TooLarge { what, got } => write!(f, "{what} = {got} does not fit the header field"),
            Self::BufferTooSmall { got } => write!(f, "output buffer of {got} bytes too small"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for EncodeError {}

impl From<DecodeError> for EncodeError {
    fn from(e: DecodeError) -> Self {
        Self::Invalid(e)
    }
}
