use shared::frame::{self, Fault, HEADER_LEN, Header, Kind, MAX_FRAME, Seq};
use sim::scene::SceneBuilder;
use ssmctl::pil::*;
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::PathBuf;
use std::time::Duration;

#[test]
fn frame_crc_check_value() {
    // The catalogue check value of CRC-32/ISO-HDLC, the frame's CRC.
    assert_eq!(frame::checksum(b"123456789"), 0xCBF4_3926);
    assert_eq!(frame::checksum(b""), 0);
}

/// A reply frame as the firmware builds it.
fn reply(kind: Kind, seq: u16, payload: &[u8]) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME];
    let n = frame::encode(kind, Seq(seq), payload, &mut buf).unwrap();
    buf[..n].to_vec()
}

/// A host link to a fake device that reads one request and answers with `answer(seq)`.
fn fake(answer: impl FnOnce(u16) -> Vec<u8> + Send + 'static) -> Link {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    std::thread::spawn(move || {
        let mut dev = TcpStream::connect(addr).unwrap();
        let mut buf = [0u8; MAX_FRAME];
        dev.read_exact(&mut buf[..HEADER_LEN]).unwrap();
        let n = Header::parse(&buf).unwrap().frame_len();
        dev.read_exact(&mut buf[HEADER_LEN..n]).unwrap();
        dev.write_all(&answer(frame::decode(&buf[..n]).unwrap().seq.0)).unwrap();
        // Keep the socket open long enough for the host to time out if nothing was sent.
        std::thread::sleep(Duration::from_millis(600));
    });
    let (stream, _) = listener.accept().unwrap();
    stream.set_read_timeout(Some(Duration::from_millis(300))).unwrap();
    Link { stream, seq: Seq(41) }
}

/// A device that sends `bytes` unprompted, then keeps the socket open.
fn fake_unprompted(bytes: Vec<u8>) -> Link {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    std::thread::spawn(move || {
        let mut dev = TcpStream::connect(addr).unwrap();
        dev.write_all(&bytes).unwrap();
        std::thread::sleep(Duration::from_millis(600));
    });
    let (stream, _) = listener.accept().unwrap();
    stream.set_read_timeout(Some(Duration::from_millis(300))).unwrap();
    Link { stream, seq: Seq(0) }
}

#[test]
fn link_waits_for_the_hello() {
    assert!(fake_unprompted(reply(Kind::Ack, u16::MAX, &[])).hello().is_ok());
    for (bytes, says) in [
        (reply(Kind::Ack, 0, &[]), "kind 0x81 seq 0 payload [], not the hello"),
        (reply(Kind::Ack, u16::MAX, &[1]), "payload [1], not the hello"),
        (reply(Kind::Error, u16::MAX, &[1]), "kind 0xee"),
        (Vec::new(), "no reply within the timeout"),
    ] {
        let e = fake_unprompted(bytes).hello().unwrap_err().to_string();
        assert!(e.contains(says) && e.contains("65535"), "{e}");
    }
}

#[test]
fn link_accepts_a_good_reply() {
    let mut l = fake(|seq| reply(Kind::Ack, seq, &[3]));
    assert_eq!(l.transact(Kind::Load, &[]).unwrap(), (Kind::Ack, vec![3]));
    assert_eq!(l.seq, Seq(42));
}

#[test]
fn link_names_lost_or_duplicated_frames() {
    let mut l = fake(|seq| reply(Kind::Ack, seq.wrapping_sub(1), &[]));
    let e = l.transact(Kind::Load, &[]).unwrap_err().to_string();
    assert!(e.contains("frame 41") && e.contains("sequence number 40") && e.contains("lost or duplicated"), "{e}");
}

#[test]
fn link_names_corrupt_replies() {
    let mut l = fake(|seq| {
        let mut f = reply(Kind::StepReply, seq, &[0; 10]);
        f[7] ^= 1;
        f
    });
    let e = l.transact(Kind::Step, &[0; 12]).unwrap_err().to_string();
    assert!(e.contains("CRC") && e.contains("corrupt frame"), "{e}");
}

#[test]
fn link_names_device_faults_and_timeouts() {
    let mut l = fake(|seq| reply(Kind::Error, seq, &[Fault::Seq.code()]));
    let e = l.transact(Kind::Prime, &[0; 8]).unwrap_err().to_string();
    assert!(e.contains("refused frame 41") && e.contains("unexpected sequence number"), "{e}");
    let mut l = fake(|_| Vec::new());
    let e = l.transact(Kind::Prime, &[0; 8]).unwrap_err().to_string();
    assert!(e.contains("no reply within the timeout"), "{e}");
    let mut l = fake(|seq| reply(Kind::StepReply, seq, &[0; 10]));
    let e = l.transact(Kind::Prime, &[0; 8]).unwrap_err().to_string();
    assert!(e.contains("expected 0x81"), "{e}");
}

fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ssm-pil-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `theta.csv` loads with the data-set loader and gives back the measured angles bit for
/// bit; `record.csv` has its documented columns, `NaN` before the predictor is ready.
#[test]
fn recorded_csv_files_load_back_exactly() {
    let dir = temp_dir("rec");
    let dt = 0.025;
    let h = 3.141592653589793e-3;
    let rows: Vec<RecordRow> = (0..50)
        .map(|i| {
            let t = i as f64 * dt;
            let theta = 0.02 * (3.1 * t).cos() + 1e-5 * i as f64;
            let q = (theta / h).floor() as i32;
            RecordRow {
                t,
                theta,
                phi: -0.4 * t,
                theta_meas: f64::from(q) * h,
                code: 7 - i,
                prediction: (i >= 25).then(|| (0.01 * f64::from(i)) as f32 + 1e-9),
            }
        })
        .collect();
    // A run that fails before the end leaves no data set (nor temporary files).
    {
        let mut r = Recorder::create(&dir).unwrap();
        for row in &rows[..10] {
            r.row(row).unwrap();
        }
    }
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "a failed run left files");
    let mut r = Recorder::create(&dir).unwrap();
    for row in &rows {
        r.row(row).unwrap();
    }
    r.finish().unwrap();

    let ts = ssm::data::load_csv(dir.join("theta.csv")).unwrap();
    assert_eq!(ts.len(), rows.len());
    for (row, (&t, &x)) in rows.iter().zip(ts.t.iter().zip(&ts.x)) {
        assert_eq!((t.to_bits(), x.to_bits()), (row.t.to_bits(), row.theta_meas.to_bits()));
    }
    assert!((ts.dt().unwrap() - dt).abs() < 1e-15);
    // Measured values are whole counts.
    assert!(ts.x.iter().all(|x| ((x / h).round() * h - x).abs() < 1e-15));

    let text = std::fs::read_to_string(dir.join("record.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(RECORD_HEADER));
    for (row, line) in rows.iter().zip(lines) {
        let c: Vec<&str> = line.split(',').collect();
        assert_eq!(c.len(), 6, "{line}");
        let f = |k: usize| c[k].parse::<f64>().unwrap();
        assert_eq!(
            [f(0), f(1), f(2), f(3)].map(f64::to_bits),
            [row.t, row.theta, row.phi, row.theta_meas].map(f64::to_bits)
        );
        assert_eq!(c[4].parse::<i32>().unwrap(), row.code);
        match row.prediction {
            Some(p) => assert_eq!(c[5].parse::<f32>().unwrap().to_bits(), p.to_bits()),
            None => assert_eq!(c[5], "NaN"),
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The comparison with the host-only simulation passes on the simulation's own output
/// (noisy quantized scene) and names the first period that differs.
#[test]
fn host_sim_comparison_finds_the_first_mismatch() {
    let scene = SceneBuilder::load("furuta-quant-dt25-noise").unwrap().periods(120).build().unwrap();
    let tr = sim::closed_loop::simulate(&scene, None).unwrap();
    let mut codes = tr.codes.clone().unwrap();
    let states: Vec<[f64; 4]> = (0..tr.rows()).map(|i| std::array::from_fn(|k| tr.state(i, k))).collect();
    let plant = sim::closed_loop::build_plant(&scene).unwrap();
    let mut s = summary_for_test();
    compare_with_host_sim(&scene, &plant, &codes, &states, &mut s).unwrap();
    assert!(s.host_sim_codes_identical && s.host_sim_first_mismatch.is_none() && s.host_sim_max_state_diff == 0.0);
    // The seed matters: another seed changes some encoder count within 120 periods (the
    // plant is the same, so the one built plant serves both scenes).
    let other = SceneBuilder::load("furuta-quant-dt25-noise").unwrap().periods(120).noise_seed(2).build().unwrap();
    compare_with_host_sim(&other, &plant, &codes, &states, &mut s).unwrap();
    assert!(!s.host_sim_codes_identical && s.host_sim_first_mismatch.is_some());
    codes[77].code += 1;
    compare_with_host_sim(&scene, &plant, &codes, &states, &mut s).unwrap();
    assert_eq!((s.host_sim_codes_identical, s.host_sim_first_mismatch), (false, Some(77)));
}

fn summary_for_test() -> PilSummary {
    PilSummary::initial(String::new(), None, String::new())
}

#[test]
fn request_layout() {
    let o = Outgoing::new(Kind::Step, Seq(0x0102), &[9, 8, 7]).unwrap();
    let f = o.bytes();
    assert_eq!(&f[..8], &[0xA5, 4, 0x02, 0x01, 3, 9, 8, 7]);
    assert_eq!(u32::from_le_bytes([f[8], f[9], f[10], f[11]]), frame::checksum(&f[..8]));
    let e = Outgoing::new(Kind::ModelChunk, Seq(3), &[0; 256]).err().unwrap().to_string();
    assert!(e.contains("frame 3") && e.contains("256 bytes"), "{e}");
}
