//! The PIL frame: CRC check value, golden bytes (as the host and firmware wrote them before
//! `shared::frame` existed), round trips, and rejection of corrupt, truncated and arbitrary
//! input.

use proptest::prelude::*;
use shared::frame::{
    self, CRC_LEN, Direction, Fault, FrameError, HEADER_LEN, Header, Kind, MAX_FRAME, MAX_PAYLOAD, REPLY_START,
    REQUEST_START, Receiver, Seq,
};

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn encoded(kind: Kind, seq: u16, payload: &[u8]) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME];
    let n = frame::encode(kind, Seq(seq), payload, &mut buf).unwrap();
    buf[..n].to_vec()
}

/// The CRC in the last four bytes, little-endian.
fn stated_crc(f: &[u8]) -> u32 {
    u32::from_le_bytes(f[f.len() - CRC_LEN..].try_into().unwrap())
}

#[test]
fn crc_is_crc32_iso_hdlc() {
    // The catalogue check value of CRC-32/ISO-HDLC, and the empty input.
    assert_eq!(frame::checksum(b"123456789"), 0xCBF4_3926);
    assert_eq!(frame::checksum(b""), 0);
    // A frame's CRC covers header and payload.
    let f = encoded(Kind::Prime, 0x0A0B, &[1, 2, 3, 4, 5, 6, 7, 8]);
    assert_eq!(stated_crc(&f), frame::checksum(&f[..f.len() - CRC_LEN]));
}

/// Recomputes the CRC of a frame whose header or payload was edited.
fn reseal(f: &mut [u8]) {
    let n = f.len() - CRC_LEN;
    let crc = frame::checksum(&f[..n]);
    f[n..].copy_from_slice(&crc.to_le_bytes());
}

// Golden frames, byte for byte as the hand-written encoders built them before this module
// (the host's request encoder for requests, the firmware's `reply`, mirrored by the host tests'
// `reply`, for replies); fields: start, kind, seq, len, payload, CRC.

/// A step request: seq 0x0102, `q_y = 0x40302010, q_z = -2, sample = 1.0f32`.
const STEP_REQUEST: &str = "a5 04 0201 0c 10203040 feffffff 0000803f d2371b35";
/// A shutdown request: seq 0xFFFF, empty payload.
const SHUTDOWN_REQUEST: &str = "a5 05 ffff 00 56de8764";
/// A step reply: seq 0x0102, `code = 5, saturated, ready, prediction = 1.5f32`.
const STEP_REPLY: &str = "5a 84 0201 0a 05000000 01 01 0000c03f b89045d0";
/// An error reply: seq 7, fault 1 (bad CRC).
const CRC_ERROR_REPLY: &str = "5a ee 0700 01 01 e2caf878";

fn unspaced(s: &str) -> String {
    s.replace(' ', "")
}

#[test]
fn golden_request_frames() {
    let payload = [0x10, 0x20, 0x30, 0x40, 0xFE, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x80, 0x3F];
    let f = encoded(Kind::Step, 0x0102, &payload);
    assert_eq!(hex(&f), unspaced(STEP_REQUEST));
    let d = frame::decode(&f).unwrap();
    assert_eq!((d.kind, d.seq, d.payload), (Kind::Step, Seq(0x0102), &payload[..]));
    assert_eq!(hex(&encoded(Kind::Shutdown, 0xFFFF, &[])), unspaced(SHUTDOWN_REQUEST));
}

#[test]
fn golden_reply_frames() {
    let payload = [5, 0, 0, 0, 1, 1, 0x00, 0x00, 0xC0, 0x3F];
    let f = encoded(Kind::StepReply, 0x0102, &payload);
    assert_eq!(hex(&f), unspaced(STEP_REPLY));
    let d = frame::decode(&f).unwrap();
    assert_eq!((d.kind, d.seq, d.payload), (Kind::StepReply, Seq(0x0102), &payload[..]));
    assert_eq!(hex(&encoded(Kind::Error, 7, &[Fault::Crc.code()])), unspaced(CRC_ERROR_REPLY));
}

#[test]
fn codes_and_directions() {
    for k in Kind::ALL {
        assert_eq!(Kind::from_code(k.code()), Some(k));
        assert_eq!(k.success_reply().is_some(), k.direction() == Direction::Request);
        if let Some(r) = k.success_reply() {
            assert_eq!(r.direction(), Direction::Reply);
        }
    }
    let codes: Vec<u8> = Kind::ALL.iter().map(|k| k.code()).collect();
    assert_eq!(codes, [1, 2, 3, 4, 5, 0x81, 0x84, 0xEE]);
    assert_eq!((Kind::Step.success_reply(), Kind::Load.success_reply()), (Some(Kind::StepReply), Some(Kind::Ack)));
    assert_eq!((0..=255).filter_map(Kind::from_code).count(), Kind::ALL.len());
    for (i, f) in Fault::ALL.iter().enumerate() {
        assert_eq!(usize::from(f.code()), i + 1);
        assert_eq!(Fault::from_code(f.code()), Some(*f));
    }
    assert_eq!((Fault::from_code(0), Fault::from_code(9)), (None, None));
    assert_eq!(Fault::Crc.description(), "bad CRC (corrupt frame)");
    assert_eq!(Direction::from_start_byte(REQUEST_START), Some(Direction::Request));
    assert_eq!(Direction::from_start_byte(REPLY_START), Some(Direction::Reply));
    assert_eq!(Seq(0xFFFF).next(), Seq(0));
}

#[test]
fn encode_errors() {
    let mut buf = [0u8; MAX_FRAME + 1];
    assert_eq!(frame::encode(Kind::ModelChunk, Seq(0), &[0; MAX_PAYLOAD], &mut buf), Ok(MAX_FRAME));
    assert_eq!(
        frame::encode(Kind::ModelChunk, Seq(0), &[0; MAX_PAYLOAD + 1], &mut buf),
        Err(FrameError::PayloadTooLong { len: MAX_PAYLOAD + 1, max: MAX_PAYLOAD })
    );
    let mut small = [0u8; HEADER_LEN + 3 + CRC_LEN - 1];
    assert_eq!(
        frame::encode(Kind::Ack, Seq(1), &[1, 2, 3], &mut small),
        Err(FrameError::BufferTooSmall { need: 12, got: 11 })
    );
    assert_eq!(frame::encode(Kind::Ack, Seq(1), &[1, 2], &mut small), Ok(11));
}

#[test]
fn decode_errors_name_what_is_wrong() {
    let f = encoded(Kind::Prime, 9, &[0; 8]);
    // A corrupted payload byte (as the host's error-path check sends): a CRC mismatch that
    // still names the frame's number.
    let mut bad = f.clone();
    bad[6] ^= 0x40;
    assert_eq!(
        frame::decode(&bad),
        Err(FrameError::Crc { seq: Seq(9), stated: stated_crc(&f), computed: frame::checksum(&bad[..13]) })
    );
    // Unknown kinds with a good CRC, and kinds of the other direction.
    let mut unknown = encoded(Kind::Ack, 3, &[]);
    unknown[1] = 0x99;
    reseal(&mut unknown);
    assert_eq!(
        frame::decode(&unknown),
        Err(FrameError::UnknownKind { direction: Direction::Reply, kind: 0x99, seq: Seq(3) })
    );
    let mut wrong_way = encoded(Kind::Load, 4, &[]);
    wrong_way[0] = REPLY_START;
    reseal(&mut wrong_way);
    assert_eq!(
        frame::decode(&wrong_way),
        Err(FrameError::UnknownKind { direction: Direction::Reply, kind: 2, seq: Seq(4) })
    );
    let mut start = f.clone();
    start[0] = 0x00;
    assert_eq!(frame::decode(&start), Err(FrameError::BadStart(0)));
    let mut long = f.clone();
    long.push(0);
    assert_eq!(frame::decode(&long), Err(FrameError::TrailingBytes { frame_len: f.len(), got: f.len() + 1 }));
    assert_eq!(frame::decode(&f[..3]), Err(FrameError::Truncated { need: HEADER_LEN, got: 3 }));
    assert_eq!(frame::decode(&f[..f.len() - 1]), Err(FrameError::Truncated { need: f.len(), got: f.len() - 1 }));
    let e = FrameError::Crc { seq: Seq(9), stated: 1, computed: 2 }.to_string();
    assert_eq!(e, "frame 9: CRC 0x00000001 != computed 0x00000002 (corrupt frame)");
}

#[test]
fn header_gives_the_frame_length() {
    let f = encoded(Kind::ModelChunk, 0x1234, &[7; 200]);
    let h = Header::parse(&f[..HEADER_LEN]).unwrap();
    assert_eq!(h, Header { direction: Direction::Request, kind: 1, seq: Seq(0x1234), len: 200 });
    assert_eq!((h.payload_len(), h.frame_len()), (200, f.len()));
    assert_eq!(frame::frame_len(200), f.len());
    assert_eq!(Header::parse(&f[..4]), Err(FrameError::Truncated { need: HEADER_LEN, got: 4 }));
}

/// Every single-byte change of a frame (each position, each other value) is rejected: the
/// frame's own length changes (truncated / trailing), or the start byte, or the CRC.
fn assert_every_byte_change_rejected(f: &[u8]) {
    for i in 0..f.len() {
        for v in 0..=255u8 {
            if v == f[i] {
                continue;
            }
            let mut g = f.to_vec();
            g[i] = v;
            assert!(frame::decode(&g).is_err(), "byte {i} = {v:#04x} accepted in {}", hex(f));
        }
    }
}

#[test]
fn every_single_byte_corruption_is_rejected() {
    assert_every_byte_change_rejected(&hex_bytes(STEP_REQUEST));
    assert_every_byte_change_rejected(&hex_bytes(STEP_REPLY));
    assert_every_byte_change_rejected(&hex_bytes(CRC_ERROR_REPLY));
    assert_every_byte_change_rejected(&hex_bytes(SHUTDOWN_REQUEST));
    assert_every_byte_change_rejected(&encoded(Kind::ModelChunk, 0xBEEF, &(0..=254).collect::<Vec<u8>>()));
}

#[test]
fn every_truncation_is_rejected() {
    for f in [hex_bytes(STEP_REPLY), encoded(Kind::ModelChunk, 1, &[0xAB; MAX_PAYLOAD]), encoded(Kind::Load, 2, &[])] {
        for n in 0..f.len() {
            let need = if n < HEADER_LEN { HEADER_LEN } else { f.len() };
            assert_eq!(frame::decode(&f[..n]), Err(FrameError::Truncated { need, got: n }));
        }
    }
}

#[test]
fn receiver_skips_noise_and_survives_a_corrupt_frame() {
    let good = encoded(Kind::Step, 5, &[1; 12]);
    let mut bad = encoded(Kind::Prime, 6, &[0; 8]);
    bad[7] ^= 1;
    let unknown = {
        let mut u = encoded(Kind::Load, 7, &[]);
        u[1] = 0x42;
        reseal(&mut u);
        u
    };
    let mut stream = vec![0x00, 0x5A, 0xFF];
    for f in [&good, &bad, &unknown, &good] {
        stream.extend_from_slice(f);
    }
    let mut rx = Receiver::new(Direction::Request);
    let mut got = Vec::new();
    for &b in &stream {
        if let Some(r) = rx.push(b) {
            got.push(r.map(|f| (f.kind, f.seq, f.payload.to_vec())));
        }
    }
    let crc_err = frame::decode(&bad).unwrap_err();
    assert!(matches!(crc_err, FrameError::Crc { seq: Seq(6), .. }));
    assert_eq!(
        got,
        [
            Ok((Kind::Step, Seq(5), vec![1; 12])),
            Err(crc_err),
            Err(FrameError::UnknownKind { direction: Direction::Request, kind: 0x42, seq: Seq(7) }),
            Ok((Kind::Step, Seq(5), vec![1; 12])),
        ]
    );
}

fn hex_bytes(s: &str) -> Vec<u8> {
    let s = unspaced(s);
    (0..s.len()).step_by(2).map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap()).collect()
}

fn any_kind() -> impl Strategy<Value = Kind> {
    proptest::sample::select(Kind::ALL.to_vec())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn round_trip(kind in any_kind(), seq in any::<u16>(), payload in proptest::collection::vec(any::<u8>(), 0..=MAX_PAYLOAD)) {
        let mut buf = [0u8; MAX_FRAME];
        let n = frame::encode(kind, Seq(seq), &payload, &mut buf).unwrap();
        prop_assert_eq!(n, frame::frame_len(payload.len()));
        prop_assert_eq!(buf[0], kind.direction().start_byte());
        let f = frame::decode(&buf[..n]).unwrap();
        prop_assert_eq!((f.kind, f.seq, f.payload), (kind, Seq(seq), &payload[..]));
        prop_assert_eq!(f.wire_len(), n);
        // The same frame, fed byte by byte after noise, to a receiver of its direction.
        let mut rx = Receiver::new(kind.direction());
        let noise = [0x00, 0x11, 0xFF];
        for &b in &noise {
            prop_assert!(rx.push(b).is_none());
        }
        for (i, &b) in buf[..n].iter().enumerate() {
            match rx.push(b) {
                None => prop_assert!(i + 1 < n),
                Some(r) => {
                    prop_assert_eq!(i + 1, n);
                    let g = r.unwrap();
                    prop_assert_eq!((g.kind, g.seq, g.payload), (kind, Seq(seq), &payload[..]));
                }
            }
        }
    }

    #[test]
    fn single_byte_corruption_is_rejected(
        kind in any_kind(),
        seq in any::<u16>(),
        payload in proptest::collection::vec(any::<u8>(), 0..64),
        at in any::<prop::sample::Index>(),
        delta in 1..=255u8,
    ) {
        let f = {
            let mut buf = [0u8; MAX_FRAME];
            let n = frame::encode(kind, Seq(seq), &payload, &mut buf).unwrap();
            buf[..n].to_vec()
        };
        let mut g = f.clone();
        let i = at.index(g.len());
        g[i] ^= delta;
        prop_assert!(frame::decode(&g).is_err());
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let _ = frame::decode(&bytes);
        let _ = Header::parse(&bytes);
        let mut rx = Receiver::new(Direction::Request);
        let mut rx2 = Receiver::new(Direction::Reply);
        for &b in &bytes {
            let _ = rx.push(b);
            let _ = rx2.push(b);
        }
    }

    #[test]
    fn arbitrary_frames_with_a_valid_header_never_panic(
        start in proptest::sample::select(vec![REQUEST_START, REPLY_START]),
        kind in any::<u8>(),
        len in any::<u8>(),
        body in proptest::collection::vec(any::<u8>(), 0..300),
    ) {
        let mut bytes = vec![start, kind, 0, 0, len];
        bytes.extend_from_slice(&body);
        if let Ok(f) = frame::decode(&bytes) {
            prop_assert_eq!(f.wire_len(), bytes.len());
        }
        let mut buf = [0u8; 8];
        let _ = frame::encode(Kind::Ack, Seq(0), &body, &mut buf);
    }
}

// Payloads of the load, prime and step frames (`frame::{LoadReply, Prime, Step, StepReply}`).

/// Golden payloads: the Furuta's two counts (the layout before the gain vector, unchanged
/// for two coordinates), one and four counts, and the replies.
#[test]
fn golden_payloads() {
    use frame::{Counts, LoadReply, Prime, Step, StepReply};
    let mut buf = [0u8; 32];
    let enc = |r: Result<usize, frame::PayloadError>, buf: &[u8]| hex(&buf[..r.unwrap()]);
    let two = Counts::new(&[0x4030_2010, -2]).unwrap();
    let step = Step { counts: two, sample: 1.0 };
    let n = step.encode(&mut buf);
    assert_eq!(enc(n, &buf), "10203040feffffff0000803f");
    // The whole request frame: the golden step request above, byte for byte.
    let payload = buf[..12].to_vec();
    assert_eq!(hex(&encoded(Kind::Step, 0x0102, &payload)), unspaced(STEP_REQUEST));
    assert_eq!(Step::decode(&payload), Ok(step));
    let one = Step { counts: Counts::new(&[-1]).unwrap(), sample: -0.5 };
    let n = one.encode(&mut buf);
    assert_eq!(enc(n, &buf), "ffffffff000000bf");
    assert_eq!(Step::decode(&buf[..8]), Ok(one));
    let four = Counts::new(&[1, -1, i32::MAX, i32::MIN]).unwrap();
    let n = Prime(four).encode(&mut buf);
    assert_eq!(enc(n, &buf), "01000000ffffffffffffff7f00000080");
    assert_eq!(Prime::decode(&buf[..16]), Ok(Prime(four)));
    let p = Prime::decode(&buf[..16]).unwrap();
    assert_eq!(p.0.as_slice(), &[1, -1, i32::MAX, i32::MIN]);
    assert_eq!(p.0.padded(), &[1, -1, i32::MAX, i32::MIN]);
    let n = LoadReply { delay: 3, coordinates: 2 }.encode(&mut buf);
    assert_eq!(enc(n, &buf), "0302");
    assert_eq!(LoadReply::decode(&[3, 2]), Ok(LoadReply { delay: 3, coordinates: 2 }));
    let r = StepReply { code: 5, saturated: true, ready: true, prediction: 1.5 };
    let n = r.encode(&mut buf);
    assert_eq!(enc(n, &buf), "0500000001010000c03f");
    assert_eq!(StepReply::decode(&buf[..10]), Ok(r));
    assert_eq!(hex(&encoded(Kind::StepReply, 0x0102, &buf[..10])), unspaced(STEP_REPLY));
}

#[test]
fn payload_errors_name_what_is_wrong() {
    use frame::{Counts, LoadReply, PayloadError, Prime, Step, StepReply};
    assert_eq!(Counts::new(&[]), Err(PayloadError::Counts { got: 0, max: 4 }));
    assert_eq!(Counts::new(&[0; 5]), Err(PayloadError::Counts { got: 5, max: 4 }));
    for len in [0, 3, 5, 20] {
        let e = Prime::decode(&vec![0; len]).unwrap_err();
        assert_eq!(e, PayloadError::Length { kind: Kind::Prime, len, min: 4, max: 16, step: 4 });
    }
    for len in [0, 4, 7, 13, 24] {
        assert!(matches!(Step::decode(&vec![0; len]), Err(PayloadError::Length { kind: Kind::Step, .. })), "{len}");
    }
    assert!(LoadReply::decode(&[1]).is_err());
    let e = StepReply::decode(&[0, 0, 0, 0, 2, 0, 0, 0, 0, 0]).unwrap_err();
    assert_eq!(e, PayloadError::Flag { what: "saturated", value: 2 });
    assert_eq!(e.to_string(), "saturated flag byte is 2, not 0 or 1");
    let mut small = [0u8; 7];
    let s = Step { counts: Counts::new(&[1]).unwrap(), sample: 0.0 };
    assert_eq!(s.encode(&mut small), Err(PayloadError::BufferTooSmall { need: 8, got: 7 }));
    assert!(
        Prime::decode(&[0; 5]).unwrap_err().to_string().contains("Prime payload of 5 bytes: this kind takes 4 to 16")
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    /// Every count vector and sample round-trips; any byte string decodes or is refused
    /// without panicking.
    #[test]
    fn payloads_round_trip(c in proptest::collection::vec(any::<i32>(), 1..=4), sample in any::<f32>(),
                           junk in proptest::collection::vec(any::<u8>(), 0..40)) {
        use frame::{Counts, Prime, Step, StepReply, LoadReply};
        let counts = Counts::new(&c).unwrap();
        let mut buf = [0u8; 32];
        let n = Step { counts, sample }.encode(&mut buf).unwrap();
        prop_assert_eq!(n, 4 * c.len() + 4);
        let back = Step::decode(&buf[..n]).unwrap();
        prop_assert_eq!(back.counts.as_slice(), &c[..]);
        prop_assert_eq!(back.sample.to_bits(), sample.to_bits());
        let n = Prime(counts).encode(&mut buf).unwrap();
        let p = Prime::decode(&buf[..n]).unwrap();
        prop_assert_eq!(p.0.as_slice(), &c[..]);
        let _ = (Step::decode(&junk), Prime::decode(&junk), StepReply::decode(&junk), LoadReply::decode(&junk));
    }
}
