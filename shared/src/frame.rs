//! The processor-in-the-loop frame: the one definition of the bytes the host
//! (`ssmctl::pil`) and the firmware (`qemu/src/bin/pil.rs`) exchange over UART0.
//!
//! ```text
//! [start u8, kind u8, seq u16 LE, len u8, payload (len bytes), crc u32 LE]
//!  \___________ header (HEADER_LEN = 5) ___/
//! ```
//!
//! `start` is [`REQUEST_START`] (`0xA5`, host to device) or [`REPLY_START`] (`0x5A`, device to
//! host); `crc` is CRC-32/ISO-HDLC (zlib's: reflected, polynomial `0x04C11DB7`, init and final
//! xor all ones) over header + payload. The kinds ([`Kind`]) of each direction:
//!
//! - requests: 1 model chunk (appended to the device's blob buffer), 2 load (decode the blob;
//!   reply payload [`LoadReply`]: controller delay `u8`, measured coordinates `u8`), 3 prime
//!   ([`Prime`]: one `i32` count per measured coordinate), 4 step ([`Step`]: one `i32` count
//!   per measured coordinate, then the predictor's sample `f32`), 5 shutdown;
//! - replies: `0x81` ack, `0x84` step ([`StepReply`]: `code i32, saturated u8, ready u8,
//!   prediction f32`), `0xEE` error (payload one [`Fault`] code).
//!
//! All numbers little-endian. The payloads of load, prime and step are defined here once
//! ([`LoadReply`], [`Prime`], [`Step`], [`StepReply`]: `encode` into a buffer, `decode` with
//! an error naming what is wrong); the host and the firmware both use them.
//!
//! Requests are numbered ([`Seq`]) 0, 1, 2, ... (wrapping); a reply carries its request's
//! number.
//!
//! [`encode`] writes a frame into a caller's buffer, [`decode`] checks one whole frame,
//! [`Header::parse`] gives the length of a frame from its first [`HEADER_LEN`] bytes, and
//! [`Receiver`] assembles frames from a byte stream one byte at a time (what a UART reader
//! needs). None of them allocates or panics, whatever the input.

use core::fmt;

use crate::config::MAX_GAINS;
use crate::model::CRC32;

/// First byte of a request (host to device).
pub const REQUEST_START: u8 = 0xA5;
/// First byte of a reply (device to host).
pub const REPLY_START: u8 = 0x5A;
/// Bytes before the payload: start, kind, seq (2), len.
pub const HEADER_LEN: usize = 5;
/// Bytes after the payload: the CRC-32.
pub const CRC_LEN: usize = 4;
/// Largest payload: the length field is one byte.
pub const MAX_PAYLOAD: usize = u8::MAX as usize;
/// Largest frame on the wire.
pub const MAX_FRAME: usize = frame_len(MAX_PAYLOAD);

/// Bytes on the wire of a frame with `payload_len` payload bytes.
pub const fn frame_len(payload_len: usize) -> usize {
    HEADER_LEN + payload_len + CRC_LEN
}

/// The frame's CRC-32/ISO-HDLC of `bytes` (a frame's CRC covers its header and payload).
pub fn checksum(bytes: &[u8]) -> u32 {
    CRC32.checksum(bytes)
}

/// Who sends a frame; the start byte tells.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Host to device, start byte [`REQUEST_START`].
    Request,
    /// Device to host, start byte [`REPLY_START`].
    Reply,
}

impl Direction {
    /// The start byte of this direction's frames.
    pub const fn start_byte(self) -> u8 {
        match self {
            Self::Request => REQUEST_START,
            Self::Reply => REPLY_START,
        }
    }

    /// The direction a start byte stands for (`None`: not a start byte).
    pub const fn from_start_byte(byte: u8) -> Option<Self> {
        match byte {
            REQUEST_START => Some(Self::Request),
            REPLY_START => Some(Self::Reply),
            _ => None,
        }
    }
}

/// What a frame is; the value is the `kind` byte.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Kind {
    /// Request: a chunk of the model blob, appended to the device's buffer.
    ModelChunk = 1,
    /// Request (empty): decode the blob (predictor and controller configuration); the ack
    /// carries the controller's delay (`u8`).
    Load = 2,
    /// Request: prime the controller at rest ([`Prime`]: one count per coordinate).
    Prime = 3,
    /// Request: one period ([`Step`]: one count per coordinate, then the sample `f32`).
    Step = 4,
    /// Request (empty): the device acks and exits.
    Shutdown = 5,
    /// Reply: done (payload as the request defines).
    Ack = 0x81,
    /// Reply to [`Kind::Step`] ([`StepReply`]): `code i32, saturated u8, ready u8, prediction f32`.
    StepReply = 0x84,
    /// Reply: the request was refused; payload one [`Fault`] code.
    Error = 0xEE,
}

impl Kind {
    /// Every kind, requests first.
    pub const ALL: [Kind; 8] = [
        Self::ModelChunk,
        Self::Load,
        Self::Prime,
        Self::Step,
        Self::Shutdown,
        Self::Ack,
        Self::StepReply,
        Self::Error,
    ];

    /// The `kind` byte.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The kind of a `kind` byte (`None`: no such kind).
    pub const fn from_code(code: u8) -> Option<Self> {
        Some(match code {
            1 => Self::ModelChunk,
            2 => Self::Load,
            3 => Self::Prime,
            4 => Self::Step,
            5 => Self::Shutdown,
            0x81 => Self::Ack,
            0x84 => Self::StepReply,
            0xEE => Self::Error,
            _ => return None,
        })
    }

    /// Whether this kind is sent by the host or by the device.
    pub const fn direction(self) -> Direction {
        match self {
            Self::ModelChunk | Self::Load | Self::Prime | Self::Step | Self::Shutdown => Direction::Request,
            Self::Ack | Self::StepReply | Self::Error => Direction::Reply,
        }
    }

    /// The reply a request of this kind gets when it succeeds ([`Kind::StepReply`] for a step,
    /// [`Kind::Ack`] otherwise); `None` for reply kinds.
    pub const fn success_reply(self) -> Option<Self> {
        match self {
            Self::Step => Some(Self::StepReply),
            Self::ModelChunk | Self::Load | Self::Prime | Self::Shutdown => Some(Self::Ack),
            Self::Ack | Self::StepReply | Self::Error => None,
        }
    }
}

/// Why the device refused a request: the payload of a [`Kind::Error`] reply.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Fault {
    /// The request's CRC did not match (the reply carries the corrupt frame's number).
    Crc = 1,
    /// The request's number was not the one expected.
    Seq = 2,
    /// Unknown request kind, or a payload length the kind does not take.
    Kind = 3,
    /// The model blob does not decode.
    Load = 4,
    /// Prime or step before a model was loaded.
    NotLoaded = 5,
    /// The model chunks exceed the device's blob buffer.
    BlobFull = 6,
    /// The blob's controller configuration is invalid.
    Config = 7,
    /// A prime or step carries a number of counts other than the controller's coordinates.
    Counts = 8,
}

impl Fault {
    /// Every fault, by code.
    pub const ALL: [Fault; 8] =
        [Self::Crc, Self::Seq, Self::Kind, Self::Load, Self::NotLoaded, Self::BlobFull, Self::Config, Self::Counts];

    /// The payload byte.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The fault of a payload byte (`None`: no such fault).
    pub const fn from_code(code: u8) -> Option<Self> {
        Some(match code {
            1 => Self::Crc,
            2 => Self::Seq,
            3 => Self::Kind,
            4 => Self::Load,
            5 => Self::NotLoaded,
            6 => Self::BlobFull,
            7 => Self::Config,
            8 => Self::Counts,
            _ => return None,
        })
    }

    /// What the fault means, for messages.
    pub const fn description(self) -> &'static str {
        match self {
            Self::Crc => "bad CRC (corrupt frame)",
            Self::Seq => "unexpected sequence number (lost or duplicated frame)",
            Self::Kind => "unknown kind or wrong payload length",
            Self::Load => "model blob does not decode",
            Self::NotLoaded => "no model loaded",
            Self::BlobFull => "model blob exceeds the device buffer",
            Self::Config => "the blob's controller configuration is invalid",
            Self::Counts => "the number of counts differs from the controller's measured coordinates",
        }
    }
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.description())
    }
}

/// A frame's sequence number (`u16`, little-endian on the wire, wrapping).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Seq(pub u16);

impl Seq {
    /// The number after this one (wrapping).
    #[must_use]
    pub const fn next(self) -> Self {
        Self(self.0.wrapping_add(1))
    }
}

impl fmt::Display for Seq {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.0, f)
    }
}

/// The first [`HEADER_LEN`] bytes of a frame, fields as on the wire (the kind is not checked:
/// that needs the CRC first, see [`decode`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    pub direction: Direction,
    /// The `kind` byte.
    pub kind: u8,
    pub seq: Seq,
    /// The payload length.
    pub len: u8,
}

impl Header {
    /// Reads the header at the start of `bytes` (only the first [`HEADER_LEN`] bytes are
    /// looked at); fails on a short slice or a wrong start byte.
    pub fn parse(bytes: &[u8]) -> Result<Self, FrameError> {
        let Some(&[start, kind, s0, s1, len]) = bytes.first_chunk::<HEADER_LEN>() else {
            return Err(FrameError::Truncated { need: HEADER_LEN, got: bytes.len() });
        };
        let direction = Direction::from_start_byte(start).ok_or(FrameError::BadStart(start))?;
        Ok(Self { direction, kind, seq: Seq(u16::from_le_bytes([s0, s1])), len })
    }

    /// Payload bytes of the frame.
    pub const fn payload_len(&self) -> usize {
        self.len as usize
    }

    /// Bytes on the wire of the whole frame, header and CRC included.
    pub const fn frame_len(&self) -> usize {
        frame_len(self.payload_len())
    }
}

/// A checked frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Frame<'a> {
    /// The kind; its direction is the start byte's.
    pub kind: Kind,
    pub seq: Seq,
    pub payload: &'a [u8],
}

impl Frame<'_> {
    /// Bytes on the wire of this frame.
    pub const fn wire_len(&self) -> usize {
        frame_len(self.payload.len())
    }
}

/// Why a frame could not be encoded or was rejected. [`decode`] checks, in this order: the
/// header is there, the start byte, the length, the CRC, the kind (the CRC before the kind,
/// so a corrupted kind byte reads as corruption).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// [`encode`]: the payload is longer than [`MAX_PAYLOAD`].
    PayloadTooLong { len: usize, max: usize },
    /// [`encode`]: the output buffer cannot hold the frame.
    BufferTooSmall { need: usize, got: usize },
    /// Fewer bytes than the header, or than the header's length field implies.
    Truncated { need: usize, got: usize },
    /// The first byte is neither [`REQUEST_START`] nor [`REPLY_START`].
    BadStart(u8),
    /// More bytes than the header's length field implies.
    TrailingBytes { frame_len: usize, got: usize },
    /// The CRC in the frame differs from the one computed over header and payload; `seq` is
    /// the (possibly corrupt) header's number, for the reply.
    Crc { seq: Seq, stated: u32, computed: u32 },
    /// The CRC is good but the `kind` byte is no kind of the start byte's direction.
    UnknownKind { direction: Direction, kind: u8, seq: Seq },
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::PayloadTooLong { len, max } => write!(f, "payload of {len} bytes exceeds the frame's {max}"),
            Self::BufferTooSmall { need, got } => write!(f, "frame needs {need} bytes, buffer has {got}"),
            Self::Truncated { need, got } => write!(f, "frame truncated: need {need} bytes, got {got}"),
            Self::BadStart(b) => {
                write!(f, "frame starts with byte {b:#04x}, not {REQUEST_START:#04x} or {REPLY_START:#04x}")
            }
            Self::TrailingBytes { frame_len, got } => {
                write!(f, "frame has trailing bytes: {frame_len} bytes long, got {got}")
            }
            Self::Crc { seq, stated, computed } => {
                write!(f, "frame {seq}: CRC {stated:#010x} != computed {computed:#010x} (corrupt frame)")
            }
            Self::UnknownKind { direction, kind, seq } => {
                let what = match direction {
                    Direction::Request => "request",
                    Direction::Reply => "reply",
                };
                write!(f, "frame {seq}: unknown {what} kind {kind:#04x}")
            }
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for FrameError {}

/// Writes the frame `kind, seq, payload` into the start of `buf` (start byte from the kind's
/// direction) and returns its length, [`frame_len`]`(payload.len())`.
pub fn encode(kind: Kind, seq: Seq, payload: &[u8], buf: &mut [u8]) -> Result<usize, FrameError> {
    let Ok(len) = u8::try_from(payload.len()) else {
        return Err(FrameError::PayloadTooLong { len: payload.len(), max: MAX_PAYLOAD });
    };
    let n = frame_len(payload.len());
    let got = buf.len();
    let Some(out) = buf.get_mut(..n) else {
        return Err(FrameError::BufferTooSmall { need: n, got });
    };
    let (head, rest) = out.split_at_mut(HEADER_LEN);
    let (body, crc) = rest.split_at_mut(payload.len());
    let [s0, s1] = seq.0.to_le_bytes();
    head.copy_from_slice(&[kind.direction().start_byte(), kind.code(), s0, s1, len]);
    body.copy_from_slice(payload);
    let mut digest = CRC32.digest();
    digest.update(head);
    digest.update(body);
    crc.copy_from_slice(&digest.finalize().to_le_bytes());
    Ok(n)
}

/// Checks that `bytes` is exactly one frame (start byte, length, CRC, then kind: see
/// [`FrameError`]) and returns it, the payload borrowed from `bytes`.
pub fn decode(bytes: &[u8]) -> Result<Frame<'_>, FrameError> {
    let header = Header::parse(bytes)?;
    let n = header.frame_len();
    if bytes.len() < n {
        return Err(FrameError::Truncated { need: n, got: bytes.len() });
    }
    if bytes.len() > n {
        return Err(FrameError::TrailingBytes { frame_len: n, got: bytes.len() });
    }
    let (covered, crc) = bytes.split_at(n - CRC_LEN);
    let computed = checksum(covered);
    let stated = match crc.first_chunk::<CRC_LEN>() {
        Some(c) => u32::from_le_bytes(*c),
        None => return Err(FrameError::Truncated { need: n, got: bytes.len() }),
    };
    if stated != computed {
        return Err(FrameError::Crc { seq: header.seq, stated, computed });
    }
    let unknown = FrameError::UnknownKind { direction: header.direction, kind: header.kind, seq: header.seq };
    let kind = Kind::from_code(header.kind).ok_or(unknown)?;
    if kind.direction() != header.direction {
        return Err(unknown);
    }
    let payload = covered.get(HEADER_LEN..).unwrap_or_default();
    Ok(Frame { kind, seq: header.seq, payload })
}

/// Assembles frames of one direction from a byte stream, one byte at a time: bytes before a
/// start byte are skipped; from a start byte on, the header and then as many bytes as its
/// length field says make one frame, which is then [`decode`]d (also when its CRC turns out
/// bad: the stream resumes after the claimed frame).
#[derive(Clone, Debug)]
pub struct Receiver {
    start: u8,
    buf: [u8; MAX_FRAME],
    filled: usize,
    /// The last byte completed a frame: the next one starts the hunt afresh.
    complete: bool,
}

impl Receiver {
    /// A receiver of frames of `direction` (a device receives [`Direction::Request`]).
    pub const fn new(direction: Direction) -> Self {
        Self { start: direction.start_byte(), buf: [0; MAX_FRAME], filled: 0, complete: false }
    }

    /// Takes the next byte; returns the frame (or why it is rejected) when this byte
    /// completes one, `None` otherwise. The frame borrows the receiver until the next push.
    pub fn push(&mut self, byte: u8) -> Option<Result<Frame<'_>, FrameError>> {
        if self.complete {
            self.filled = 0;
            self.complete = false;
        }
        if self.filled == 0 && byte != self.start {
            return None;
        }
        // `filled` stays below MAX_FRAME: a frame completes at its length, at most MAX_FRAME.
        *self.buf.get_mut(self.filled)? = byte;
        self.filled += 1;
        if self.filled < HEADER_LEN || self.filled < frame_len(usize::from(self.buf[HEADER_LEN - 1])) {
            return None;
        }
        self.complete = true;
        Some(decode(self.buf.get(..self.filled).unwrap_or_default()))
    }
}

/// Why a payload of a load, prime or step frame does not decode (or encode).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PayloadError {
    /// The payload length is not one this kind takes (`min..=max` in steps of `step`).
    Length { kind: Kind, len: usize, min: usize, max: usize, step: usize },
    /// A flag byte is neither 0 nor 1.
    Flag { what: &'static str, value: u8 },
    /// [`Prime::encode`] / [`Step::encode`]: no counts, or more than [`MAX_GAINS`].
    Counts { got: usize, max: usize },
    /// The output buffer cannot hold the payload.
    BufferTooSmall { need: usize, got: usize },
}

impl fmt::Display for PayloadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Length { kind, len, min, max, step } => {
                write!(f, "{kind:?} payload of {len} bytes: this kind takes {min} to {max} bytes in steps of {step}")
            }
            Self::Flag { what, value } => write!(f, "{what} flag byte is {value}, not 0 or 1"),
            Self::Counts { got, max } => write!(f, "{got} counts: a frame carries 1 to {max}"),
            Self::BufferTooSmall { need, got } => write!(f, "payload needs {need} bytes, buffer has {got}"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for PayloadError {}

/// The counts of one sample: one `i32` per measured coordinate, 1 to [`MAX_GAINS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Counts {
    n: u8,
    c: [i32; MAX_GAINS],
}

impl Counts {
    /// The counts `c` (1 to [`MAX_GAINS`] of them).
    pub fn new(c: &[i32]) -> Result<Self, PayloadError> {
        let mut all = [0; MAX_GAINS];
        match all.get_mut(..c.len()) {
            Some(dst) if !c.is_empty() => {
                dst.copy_from_slice(c);
                // 1..=MAX_GAINS: fits u8.
                Ok(Self { n: c.len() as u8, c: all })
            }
            _ => Err(PayloadError::Counts { got: c.len(), max: MAX_GAINS }),
        }
    }

    /// The counts, in gain order.
    pub fn as_slice(&self) -> &[i32] {
        self.c.get(..usize::from(self.n)).unwrap_or_default()
    }

    /// All [`MAX_GAINS`] slots, unused ones zero (what `controller::IntPd::step_counts` takes).
    pub fn padded(&self) -> &[i32; MAX_GAINS] {
        &self.c
    }

    fn write(&self, out: &mut [u8]) {
        for (dst, c) in out.chunks_exact_mut(4).zip(self.as_slice()) {
            dst.copy_from_slice(&c.to_le_bytes());
        }
    }

    fn read(bytes: &[u8]) -> Self {
        let mut c = [0; MAX_GAINS];
        let mut n = 0u8;
        for (dst, src) in c.iter_mut().zip(bytes.chunks_exact(4)) {
            if let Some(w) = src.first_chunk::<4>() {
                *dst = i32::from_le_bytes(*w);
                n += 1;
            }
        }
        Self { n, c }
    }
}

fn out(buf: &mut [u8], need: usize) -> Result<&mut [u8], PayloadError> {
    let got = buf.len();
    buf.get_mut(..need).ok_or(PayloadError::BufferTooSmall { need, got })
}

/// The payload of a [`Kind::Prime`] request: the controller starts at rest at these counts
/// (`4 n` bytes, `n` = the coordinates).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Prime(pub Counts);

impl Prime {
    /// Largest payload, bytes.
    pub const MAX_LEN: usize = 4 * MAX_GAINS;

    /// Writes the payload into `buf`; returns its length.
    pub fn encode(&self, buf: &mut [u8]) -> Result<usize, PayloadError> {
        let n = 4 * self.0.as_slice().len();
        self.0.write(out(buf, n)?);
        Ok(n)
    }

    /// Reads a payload of 4 to [`Prime::MAX_LEN`] bytes, a multiple of 4.
    pub fn decode(p: &[u8]) -> Result<Self, PayloadError> {
        if p.is_empty() || p.len() > Self::MAX_LEN || !p.len().is_multiple_of(4) {
            return Err(PayloadError::Length { kind: Kind::Prime, len: p.len(), min: 4, max: Self::MAX_LEN, step: 4 });
        }
        Ok(Self(Counts::read(p)))
    }
}

/// The payload of a [`Kind::Step`] request: the counts read at this sample (`4 n` bytes), then
/// the predictor's sample `f32` (4 bytes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    pub counts: Counts,
    pub sample: f32,
}

impl Step {
    /// Largest payload, bytes.
    pub const MAX_LEN: usize = 4 * MAX_GAINS + 4;

    /// Writes the payload into `buf`; returns its length.
    pub fn encode(&self, buf: &mut [u8]) -> Result<usize, PayloadError> {
        let n = 4 * self.counts.as_slice().len();
        let (c, s) = out(buf, n + 4)?.split_at_mut(n);
        self.counts.write(c);
        s.copy_from_slice(&self.sample.to_le_bytes());
        Ok(n + 4)
    }

    /// Reads a payload of 8 to [`Step::MAX_LEN`] bytes, a multiple of 4.
    pub fn decode(p: &[u8]) -> Result<Self, PayloadError> {
        let bad = PayloadError::Length { kind: Kind::Step, len: p.len(), min: 8, max: Self::MAX_LEN, step: 4 };
        if p.len() < 8 || p.len() > Self::MAX_LEN || !p.len().is_multiple_of(4) {
            return Err(bad);
        }
        let (c, s) = p.split_at(p.len() - 4);
        let sample = f32::from_le_bytes(*s.first_chunk::<4>().ok_or(bad)?);
        Ok(Self { counts: Counts::read(c), sample })
    }
}

/// The payload of the [`Kind::Ack`] to a [`Kind::Load`]: the loaded controller's delay and
/// number of measured coordinates (2 bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LoadReply {
    /// Delay `r` in samples (saturated at 255).
    pub delay: u8,
    pub coordinates: u8,
}

impl LoadReply {
    pub const LEN: usize = 2;

    pub fn encode(&self, buf: &mut [u8]) -> Result<usize, PayloadError> {
        out(buf, Self::LEN)?.copy_from_slice(&[self.delay, self.coordinates]);
        Ok(Self::LEN)
    }

    pub fn decode(p: &[u8]) -> Result<Self, PayloadError> {
        match *p {
            [delay, coordinates] => Ok(Self { delay, coordinates }),
            _ => Err(PayloadError::Length { kind: Kind::Ack, len: p.len(), min: 2, max: 2, step: 1 }),
        }
    }
}

/// The payload of a [`Kind::StepReply`]: `code i32, saturated u8, ready u8, prediction f32`
/// (10 bytes); the prediction is 0 and `ready` false until the predictor's window is full.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepReply {
    pub code: i32,
    pub saturated: bool,
    pub ready: bool,
    pub prediction: f32,
}

impl StepReply {
    pub const LEN: usize = 10;

    pub fn encode(&self, buf: &mut [u8]) -> Result<usize, PayloadError> {
        let o = out(buf, Self::LEN)?;
        let [c0, c1, c2, c3] = self.code.to_le_bytes();
        let [p0, p1, p2, p3] = self.prediction.to_le_bytes();
        o.copy_from_slice(&[c0, c1, c2, c3, u8::from(self.saturated), u8::from(self.ready), p0, p1, p2, p3]);
        Ok(Self::LEN)
    }

    pub fn decode(p: &[u8]) -> Result<Self, PayloadError> {
        let &[c0, c1, c2, c3, sat, ready, p0, p1, p2, p3] = p else {
            return Err(PayloadError::Length {
                kind: Kind::StepReply,
                len: p.len(),
                min: Self::LEN,
                max: Self::LEN,
                step: 1,
            });
        };
        let flag = |what, value| match value {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err(PayloadError::Flag { what, value }),
        };
        Ok(Self {
            code: i32::from_le_bytes([c0, c1, c2, c3]),
            saturated: flag("saturated", sat)?,
            ready: flag("ready", ready)?,
            prediction: f32::from_le_bytes([p0, p1, p2, p3]),
        })
    }
}
