//! The bodies of the coverage-guided fuzz targets (docs/decisions/0004): one function per input
//! boundary, taking arbitrary bytes. The libFuzzer harness (`tests/fuzz`, nightly and
//! cargo-fuzz) calls them under coverage guidance; `tests/replay.rs` replays every seed,
//! corpus and regression file through the same functions on stable, so CI keeps what the
//! fuzzers found without a nightly toolchain.
//!
//! Each target asserts what must hold, not only "no crash": an `Err` carries a non-empty
//! message (naming the input where the boundary knows its name), an `Ok` is really valid
//! (it passes the boundary's own validation again, survives its round trip: serialize and
//! parse, encode and decode, and what one layer accepts the next one accepts too). A
//! violated property panics, which is what libFuzzer records as a finding.

use shared::frame::{self, Direction, Kind, Receiver, Seq};
use shared::model::OwnedModel;
use sim::scene::Scene;
use ssm::device::decode_host;

/// A target: its name (the harness's binary and the corpus folder) and its body.
pub type Target = (&'static str, fn(&[u8]));

/// Every target, in the order of the corpus folders.
pub const TARGETS: &[Target] = &[
    ("scene_toml", scene_toml),
    ("csv_data", csv_data),
    ("model_json", model_json),
    ("model_blob", model_blob),
    ("pil_frames", pil_frames),
    ("cli_options", cli_options),
    ("plant_expressions", plant_expressions),
    ("mat_file", mat_file),
    ("sweep_spec", sweep_spec),
    ("shard_file", shard_file),
];

/// The target called `name`.
pub fn target(name: &str) -> Option<fn(&[u8])> {
    TARGETS.iter().find(|(n, _)| *n == name).map(|(_, f)| *f)
}

/// An error message must say something (and not be a panic's text smuggled through).
fn check_message(what: &str, msg: &str) {
    assert!(!msg.trim().is_empty(), "{what}: an error with an empty message");
}

/// The label a fuzzed scene is parsed under (errors of TOML syntax name it).
const SCENE_LABEL: &str = "fuzz.toml";

/// Scene TOML: `Scene::parse` (syntax, overrides, deserialization, validation). Input: the
/// TOML text, optionally followed by a NUL byte and `--set` overrides, one a line. An
/// accepted scene validates again, has a safe file name, a controller configuration the
/// controller accepts, serializes to TOML that parses back to the same scene, and its plant
/// builds; the exact stability computation either refuses or returns finite multipliers.
pub fn scene_toml(data: &[u8]) {
    let (text, sets) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    let text = String::from_utf8_lossy(text);
    let sets: Vec<String> = String::from_utf8_lossy(sets).lines().filter(|l| !l.is_empty()).map(String::from).collect();
    let scene = match Scene::parse(SCENE_LABEL, &text, &sets) {
        Ok(s) => s,
        Err(e) => return check_message("scene", &e.to_string()),
    };
    assert_eq!(scene.validate().map_err(|e| e.to_string()), Ok(()), "an accepted scene fails its own validation");
    assert!(
        sim::scene::check_name(&scene.name).is_ok(),
        "accepted scene name {:?} is not a safe file name",
        scene.name
    );
    assert!(scene.run.periods <= sim::scene::MAX_PERIODS, "run.periods {} above the limit", scene.run.periods);
    let cfg = scene.controller_config();
    assert_eq!(
        controller::validate_config::<{ controller::HISTORY }>(&cfg),
        Ok(()),
        "accepted scene, refused configuration {cfg:?}"
    );
    assert!(scene.dt().is_finite() && scene.dt() > 0.0, "accepted scene with dt = {}", scene.dt());
    // Round trip: what the scene serializes to is a scene file that parses to the same scene.
    let again = toml::to_string(&scene).unwrap_or_else(|e| panic!("accepted scene does not serialize: {e}\n{scene:?}"));
    match Scene::parse(SCENE_LABEL, &again, &[]) {
        Ok(s) => assert_eq!(s, scene, "scene changed in a TOML round trip:\n{again}"),
        Err(e) => panic!("accepted scene, serialized, is refused: {e}\n{again}"),
    }
    match sim::closed_loop::build_plant(&scene) {
        Ok(_) => {}
        Err(e) => return check_message("plant", &e.to_string()),
    }
    if scene.wants(sim::scene::Task::Stability) {
        match sim::stability::scene_multipliers(&scene) {
            Ok(m) => {
                for x in &m {
                    assert!(x.re.is_finite() && x.im.is_finite() && x.abs.is_finite(), "non-finite multiplier {x:?}");
                }
            }
            Err(e) => check_message("stability", &e.to_string()),
        }
    }
}

/// The file name fuzzed CSV text is parsed under; every data error must name it.
const CSV_FILE: &str = "fuzz.csv";

/// CSV data (`ssm::parse_csv_column`, `parse_csv_observables`): two-column, by column name,
/// all columns. Input: the text (a leading byte picks the column name's source: the second
/// header entry, or none). An error names the file; an accepted series validates, has
/// strictly increasing finite times and finite values, and one sample per non-blank data
/// line (nothing silently dropped).
pub fn csv_data(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let data_lines = text.lines().skip(1).filter(|l| !l.trim().is_empty()).count();
    let err = |e: ssm::DataError| {
        let m = e.to_string();
        check_message("csv", &m);
        assert!(m.contains(CSV_FILE), "data error does not name the file: {m}");
    };
    match ssm::data::parse_csv(CSV_FILE, "fuzz".into(), &text) {
        Ok(s) => {
            assert_eq!(s.validate().map_err(|e| e.to_string()), Ok(()), "accepted series fails validation");
            assert_eq!(s.len(), data_lines, "{} samples from {data_lines} data lines", s.len());
            check_series(&s.t, &s.x);
        }
        Err(e) => err(e),
    }
    let column = text.lines().next().and_then(|h| h.split(',').nth(1)).map(str::trim).map(String::from);
    if let Some(c) = &column {
        match ssm::data::parse_csv_column(CSV_FILE, "fuzz".into(), &text, Some(c)) {
            Ok(s) => {
                assert_eq!(s.len(), data_lines, "{} samples from {data_lines} data lines (column {c})", s.len());
                check_series(&s.t, &s.x);
            }
            Err(e) => err(e),
        }
    }
    match ssm::data::multi::parse_csv_observables(CSV_FILE, "fuzz".into(), &text, None) {
        Ok(m) => {
            assert_eq!(m.validate().map_err(|e| e.to_string()), Ok(()), "accepted multi-series fails validation");
            assert_eq!(m.len(), data_lines, "{} samples from {data_lines} data lines (all columns)", m.len());
            assert!(m.dim() >= 1, "no observable");
            check_series(&m.t, &m.x);
            // Column selection by name picks the same values.
            for i in 0..m.dim() {
                let name = m.observables[i].clone();
                if m.observables.iter().filter(|o| **o == name).count() == 1 {
                    let one = m.select(std::slice::from_ref(&name)).unwrap_or_else(|e| panic!("select {name}: {e}"));
                    let col = m.observable(i).unwrap_or_else(|| panic!("observable {i}"));
                    assert_eq!(
                        one.x.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                        col.x.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
                    );
                }
            }
        }
        Err(e) => err(e),
    }
}

fn check_series(t: &[f64], x: &[f64]) {
    assert!(t.iter().all(|v| v.is_finite()), "non-finite time accepted");
    assert!(x.iter().all(|v| v.is_finite()), "non-finite value accepted");
    assert!(t.windows(2).all(|w| w[1] > w[0]), "times not strictly increasing");
}

/// Model JSON (`SsmModel::from_json`, then what `export` does: `to_device_model`, `encode`).
/// An accepted model validates again and survives `to_json`/`from_json`; an exported blob
/// is accepted by the host decoder with its controller check (`inspect`), and decodes to
/// the model that was encoded.
///
/// Input: JSON text (starting with `{` or white space), or else edits of a bundled fitted
/// model (structure-aware: byte mutations of JSON text rarely stay a model): the first byte
/// picks the model (RBF, polynomial map, flow, RBF of two observables), then records of 8
/// bytes, each an operation on one of the model's numbers or arrays (picked by 2 bytes)
/// with an operand (5 bytes): set a number (an integer, a power of ten, a scaled copy), cut,
/// grow or empty an array, null it.
pub fn model_json(data: &[u8]) {
    match data.first() {
        Some(b'{' | b' ' | b'\n' | b'\t' | b'\r') | None => model_json_text(&String::from_utf8_lossy(data)),
        Some(&pick) => {
            let base = MODELS[usize::from(pick) % MODELS.len()];
            let mut v: serde_json::Value =
                serde_json::from_str(base).unwrap_or_else(|e| panic!("bundled seed model: {e}"));
            for rec in data[1..].chunks_exact(8) {
                edit_model(&mut v, rec);
            }
            model_json_text(&v.to_string());
        }
    }
}

/// Fitted models the structure-aware mode of [`model_json`] edits (its seeds).
const MODELS: [&str; 4] = [
    include_str!("../../fuzz/seeds/model_json/rbf"),
    include_str!("../../fuzz/seeds/model_json/map"),
    include_str!("../../fuzz/seeds/model_json/flow"),
    include_str!("../../fuzz/seeds/model_json/multi-rbf"),
];

/// JSON pointers of every number and array under `v`.
fn pointers(v: &serde_json::Value, at: &str, out: &mut Vec<String>) {
    match v {
        serde_json::Value::Object(m) => m.iter().for_each(|(k, x)| pointers(x, &format!("{at}/{k}"), out)),
        serde_json::Value::Array(a) => {
            out.push(at.to_string());
            a.iter().enumerate().for_each(|(i, x)| pointers(x, &format!("{at}/{i}"), out));
        }
        serde_json::Value::Number(_) | serde_json::Value::Null => out.push(at.to_string()),
        _ => {}
    }
}

/// One edit of a JSON model (see [`model_json`]).
fn edit_model(v: &mut serde_json::Value, rec: &[u8]) {
    let mut ptrs = Vec::new();
    pointers(v, "", &mut ptrs);
    if ptrs.is_empty() {
        return;
    }
    let at = &ptrs[usize::from(u16::from_le_bytes([rec[0], rec[1]])) % ptrs.len()];
    let op = rec[2];
    let arg = i64::from(i32::from_le_bytes([rec[3], rec[4], rec[5], rec[6]]));
    let small = rec[7];
    let Some(x) = v.pointer_mut(at) else { return };
    match (op % 8, &mut *x) {
        (0, _) => *x = serde_json::json!(arg),
        (1, _) => *x = serde_json::json!(i64::from(small) - 2),
        (2, _) => *x = serde_json::json!(10f64.powi(i32::from(small as i8) * 3)),
        (3, serde_json::Value::Number(n)) => {
            *x = serde_json::json!(n.as_f64().unwrap_or(0.0) * (f64::from(small as i8) / 8.0))
        }
        (4, serde_json::Value::Array(a)) => a.truncate(usize::from(small) % (a.len() + 1)),
        (5, serde_json::Value::Array(a)) => {
            if let Some(last) = a.last().cloned() {
                a.extend(std::iter::repeat_n(last, usize::from(small % 16) + 1));
            }
        }
        (6, _) => *x = serde_json::Value::Array(Vec::new()),
        (7, _) => *x = serde_json::Value::Null,
        _ => *x = serde_json::json!(-arg),
    }
}

fn model_json_text(text: &str) {
    let m = match ssm::SsmModel::from_json(text) {
        Ok(m) => m,
        Err(e) => return check_message("model json", &e.to_string()),
    };
    assert_eq!(m.validate().map_err(|e| e.to_string()), Ok(()), "accepted model fails validation");
    let json = m.to_json().unwrap_or_else(|e| panic!("accepted model does not serialize: {e}"));
    let back = ssm::SsmModel::from_json(&json).unwrap_or_else(|e| panic!("accepted model, saved, is refused: {e}"));
    assert_eq!(back.to_json().ok().as_deref(), Some(json.as_str()), "model changed in a JSON round trip");
    let cfg = shared::ControllerConfig::paper(m.dt);
    if controller::validate_config::<{ controller::HISTORY }>(&cfg).is_err() {
        return;
    }
    let owned = match ssm::device::to_device_model(&m, cfg) {
        Ok(o) => o,
        Err(e) => return check_message("export", &e.to_string()),
    };
    let blob = match ssm::device::encode(&owned) {
        Ok(b) => b,
        Err(e) => return check_message("encode", &e.to_string()),
    };
    if let Err(e) = ssmctl::fit_command::inspect(&blob) {
        panic!("an exported blob is refused by inspect: {e}");
    }
    let host = decode_host(&blob).unwrap_or_else(|e| panic!("exported blob does not decode: {e}"));
    assert_eq!(bits(&host.to_owned_model()), bits(&owned), "exported blob decodes to another model");
}

/// The model with its floats as bits (NaN-safe equality).
fn bits(m: &OwnedModel) -> String {
    let b = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let c = &m.config;
    format!(
        "{:?} {:?} {:?} {:?} {:?} {} {} {} {} {} {} {} {:?} {:?} {:?} {:?} {:?}",
        c.gains.iter().map(|g| (g.index, g.p.to_bits(), g.d.to_bits(), g.h_adc.to_bits())).collect::<Vec<_>>(),
        c.gains.len(),
        (c.ki.to_bits(), c.dt.to_bits(), c.delay),
        c.u_max.map(f64::to_bits),
        c.quant.map(|q| (q.mode, q.h_dac.to_bits())),
        m.p,
        m.shift,
        m.sample_period.to_bits(),
        m.offset.to_bits(),
        m.scale.to_bits(),
        m.d,
        m.lift_order,
        (m.k,),
        b(&m.v1),
        b(&m.lift),
        (b(&m.centres), b(&m.weights)),
        b(&m.affine)
    )
}

/// CRC-32/ISO-HDLC, as the blob header carries (written here independently of `shared`).
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 { (c >> 1) ^ 0xEDB8_8320 } else { c >> 1 };
        }
    }
    !c
}

/// Model blob (`shared::model` decode into the host's capacity, then
/// `controller::validate_config`: what `ssmctl inspect` and the firmware's load do). Input:
/// a mode byte, then either the blob as is (even mode) or a payload to which a correct
/// header is prepended (odd mode: magic, version 1, length and CRC fixed, so mutations reach
/// the payload checks behind the CRC). An accepted blob's configuration is valid, it
/// re-encodes to bytes that decode to the same model, and the re-encoded blob is accepted.
pub fn model_blob(data: &[u8]) {
    let Some((&mode, rest)) = data.split_first() else { return };
    let blob: Vec<u8> = if mode % 2 == 0 {
        rest.to_vec()
    } else {
        let mut b = Vec::with_capacity(shared::model::HEADER_LEN + rest.len());
        b.extend_from_slice(&shared::model::MAGIC);
        b.extend_from_slice(&shared::model::FORMAT_VERSION.to_le_bytes());
        // Bytes 6..14 as in the header layout (dims), taken from the input when there.
        let mut dims = [0u8; 8];
        for (d, s) in dims.iter_mut().zip(rest.iter()) {
            *d = *s;
        }
        let payload = rest.get(8..).unwrap_or_default();
        b.extend_from_slice(&dims);
        b.extend_from_slice(&u32::try_from(payload.len()).unwrap_or(u32::MAX).to_le_bytes());
        b.extend_from_slice(&crc32(payload).to_le_bytes());
        b.extend_from_slice(payload);
        b
    };
    let verdict = ssmctl::fit_command::inspect(&blob);
    let host = match (&verdict, decode_host(&blob)) {
        (Err(e), _) => return check_message("blob", &e.to_string()),
        (Ok(_), Err(e)) => panic!("inspect accepts a blob the decoder refuses: {e}"),
        (Ok(_), Ok(h)) => h,
    };
    assert_eq!(
        controller::validate_config::<{ controller::HISTORY }>(host.config()),
        Ok(()),
        "accepted blob, invalid configuration"
    );
    let owned = host.to_owned_model();
    let again = owned.encode().unwrap_or_else(|e| panic!("a decoded model does not re-encode: {e}"));
    let host2 = decode_host(&again).unwrap_or_else(|e| panic!("a re-encoded model does not decode: {e}"));
    assert_eq!(bits(&host2.to_owned_model()), bits(&owned), "model changed in an encode/decode round trip");
    assert!(ssmctl::fit_command::inspect(&again).is_ok(), "re-encoded blob refused");
}

/// PIL frames (`shared::frame::decode` and the byte-wise `Receiver`). Input: a mode byte,
/// then bytes. Mode 0..=1: the bytes are one candidate frame for `decode` and a stream for a
/// receiver of each direction, compared with a reference framer written here; mode 2..: the
/// bytes are cut into frames that are encoded (valid CRCs) between noise, and a receiver
/// must return exactly those frames. An accepted frame re-encodes to the bytes it came from.
pub fn pil_frames(data: &[u8]) {
    let Some((&mode, rest)) = data.split_first() else { return };
    if mode < 2 {
        if let Ok(f) = frame::decode(rest) {
            let mut buf = [0u8; frame::MAX_FRAME];
            let n = frame::encode(f.kind, f.seq, f.payload, &mut buf)
                .unwrap_or_else(|e| panic!("decoded frame does not encode: {e}"));
            assert_eq!(&buf[..n], rest, "decode/encode round trip changed the frame");
        } else if let Err(e) = frame::decode(rest) {
            check_message("frame", &e.to_string());
        }
        for dir in [Direction::Request, Direction::Reply] {
            stream_matches_reference(dir, rest);
        }
        return;
    }
    // Valid frames between noise bytes that are not the start byte.
    let dir = if mode % 2 == 0 { Direction::Request } else { Direction::Reply };
    let kinds: Vec<Kind> = Kind::ALL.iter().copied().filter(|k| k.direction() == dir).collect();
    let mut stream = Vec::new();
    let mut sent = Vec::new();
    let mut chunks = rest.chunks(64);
    let mut seq = Seq(u16::from(mode));
    while let Some(c) = chunks.next() {
        let (&sel, payload) = match c.split_first() {
            Some(x) => x,
            None => break,
        };
        let noise = usize::from(sel >> 4);
        stream.extend(std::iter::repeat_n(dir.start_byte() ^ 0xFF, noise));
        let kind = kinds[usize::from(sel) % kinds.len()];
        let mut buf = [0u8; frame::MAX_FRAME];
        let n = frame::encode(kind, seq, payload, &mut buf).unwrap_or_else(|e| panic!("encode: {e}"));
        stream.extend_from_slice(&buf[..n]);
        sent.push((kind, seq, payload.to_vec()));
        seq = seq.next();
    }
    let mut rx = Receiver::new(dir);
    let mut got = Vec::new();
    for &b in &stream {
        if let Some(r) = rx.push(b) {
            let f = r.unwrap_or_else(|e| panic!("a valid frame is refused: {e}"));
            got.push((f.kind, f.seq, f.payload.to_vec()));
        }
    }
    assert_eq!(got, sent, "the receiver did not return the frames sent");
}

/// Feeds `bytes` to a receiver and checks each completed frame against a reference framer:
/// skip to a start byte, take the header, then as many bytes as its length field says, and
/// `decode` exactly that window.
fn stream_matches_reference(dir: Direction, bytes: &[u8]) {
    let mut rx = Receiver::new(dir);
    let mut start: Option<usize> = None;
    for (i, &b) in bytes.iter().enumerate() {
        if start.is_none() && b == dir.start_byte() {
            start = Some(i);
        }
        let expected = start.and_then(|s| {
            let window = &bytes[s..=i];
            (window.len() >= frame::HEADER_LEN
                && window.len() == frame::frame_len(usize::from(window[frame::HEADER_LEN - 1])))
            .then_some(window)
        });
        let got = rx.push(b).map(|r| r.map(|f| (f.kind, f.seq, f.payload.to_vec())));
        match (expected, got) {
            (None, None) => {}
            (Some(w), Some(g)) => {
                let want = frame::decode(w).map(|f| (f.kind, f.seq, f.payload.to_vec()));
                assert_eq!(g, want, "receiver and reference framer disagree at byte {i}");
                if let Ok((kind, _, _)) = &want {
                    assert_eq!(kind.direction(), dir, "a frame of the other direction accepted");
                }
                start = None;
            }
            (w, g) => panic!("at byte {i}: reference frame {w:?}, receiver {g:?}"),
        }
    }
}

/// The CLI's options (`ssmctl::cli::try_parse` then `ssmctl::cli::check_options`: every
/// check that needs no input file). Input: the arguments after `ssmctl`, separated by NUL
/// bytes or newlines. A refused command line has a message; an accepted one has its sizes
/// within the stated limits.
pub fn cli_options(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let args: Vec<String> = std::iter::once("ssmctl".to_string())
        .chain(text.split(['\0', '\n']).filter(|a| !a.is_empty()).map(String::from))
        .collect();
    let cli = match ssmctl::cli::try_parse(&args) {
        Ok(c) => c,
        Err(e) => {
            // --help and --version "fail" with exit code 0 and print text.
            return check_message("clap", &e.to_string());
        }
    };
    match ssmctl::cli::check_options(&cli) {
        Ok(()) => assert_within_limits(&cli.cmd),
        Err(e) => check_message("options", &e.to_string()),
    }
}

/// What an accepted command line guarantees before any work: counts and sizes within the
/// stated limits, durations finite.
fn assert_within_limits(cmd: &ssmctl::cli::Cmd) {
    use ssm::limits::{MAX_CENTERS, MAX_DIM, MAX_EMBED, MAX_ORDER, MAX_SHIFT};
    use ssmctl::cli::{BenchCmd, Cmd};
    match cmd {
        Cmd::Pil { periods, timeout, .. } => {
            assert!((1..=sim::scene::MAX_PERIODS).contains(periods), "--periods {periods} accepted");
            assert!(timeout.is_finite() && *timeout > 0.0, "--timeout {timeout} accepted");
        }
        Cmd::Bench { what: BenchCmd::Simulate { periods, .. } } => {
            assert!(*periods <= sim::scene::MAX_PERIODS, "--periods {periods} accepted")
        }
        Cmd::StabilityChart { axes, x_range, y_range, dt_ms, .. } => {
            let ranges = ssmctl::cli::chart_ranges(axes, x_range.as_deref(), y_range.as_deref())
                .unwrap_or_else(|e| panic!("accepted, then refused: {e}"));
            for (what, (lo, hi, n)) in ranges {
                assert!(
                    lo.is_finite() && hi.is_finite() && lo < hi && (2..=4000).contains(&n),
                    "--axes {what} accepted"
                );
            }
            assert!(dt_ms.iter().all(|d| d.is_finite() && *d > 0.0), "--dt-ms {dt_ms:?} accepted");
            assert!(dt_ms.len() <= sim::chart::MAX_PANELS, "{} panels accepted", dt_ms.len());
        }
        Cmd::Fit(a) => {
            // Without --auto both are required; with it they are chosen (or --dim fixed).
            assert!(a.auto || (a.dim.is_some() && a.embed.is_some()), "--dim/--embed missing without --auto accepted");
            assert!(a.dim.is_none_or(|d| (1..=MAX_DIM).contains(&d)), "--dim {:?} accepted", a.dim);
            assert!(a.embed.is_none_or(|e| e > 0 && e <= MAX_EMBED), "--embed {:?} accepted", a.embed);
            assert!((1..=MAX_SHIFT).contains(&a.shift), "--shift {} accepted", a.shift);
            assert!((1..=MAX_ORDER).contains(&a.order), "--order {} accepted", a.order);
            assert!(a.dynamics != "rbf" || (1..=MAX_CENTERS).contains(&a.centers), "--centers {} accepted", a.centers);
        }
        Cmd::Chaos { gp_embed, ssm_dim, centers, poly_order, shift, .. } => {
            assert!((1..=chaos_study::microchaos::MAX_GP_EMBED).contains(gp_embed), "--gp-embed {gp_embed} accepted");
            assert!(ssm_dim.is_none_or(|d| (1..=MAX_DIM).contains(&d)), "--ssm-dim {ssm_dim:?} accepted");
            assert!((1..=MAX_CENTERS).contains(centers), "--centers {centers} accepted");
            assert!((1..=MAX_ORDER).contains(poly_order), "--poly-order {poly_order} accepted");
            assert!(shift.is_none_or(|s| (1..=MAX_SHIFT).contains(&s)), "--shift {shift:?} accepted");
        }
        Cmd::Backbone { observable, .. } => assert!(*observable >= 1),
        Cmd::Frc { observable, mode, .. } => assert!(*observable >= 1 && *mode >= 1),
        _ => {}
    }
}

/// The plant expression language (`sim::expr`): parse, compile to a tape, evaluate. Input:
/// the expression text. A refusal names a column within the text (or one past its end); an
/// accepted expression compiles, and its tape evaluates in `f64` bit for bit as the graph
/// does (or both NaN), and in dual numbers to the same value.
pub fn plant_expressions(data: &[u8]) {
    use sim::expr::{Graph, Names, Tape, parse};
    use sim::plant::{Dual, Scalar};
    let text = String::from_utf8_lossy(data);
    let names = Names {
        vars: ["x", "theta", "x_dot", "theta_dot", "u"].iter().map(|s| s.to_string()).collect(),
        params: vec![("m".into(), 0.2), ("g".into(), 9.81), ("l".into(), 0.3)],
    };
    let mut g = Graph::new();
    let p = match parse(&text, &names, &mut g) {
        Ok(p) => p,
        Err(e) => {
            check_message("expression", &e.message);
            assert!(e.col >= 1 && e.col <= text.chars().count() + 1, "column {} outside {:?}", e.col, text);
            return;
        }
    };
    let tape = match Tape::compile(&g, &[p.root], 5) {
        Ok(t) => t,
        Err(e) => return check_message("tape", &e.to_string()),
    };
    for point in [[0.3, -1.2, 0.7, 2.5, -0.4], [0.0, 0.0, 0.0, 0.0, 0.0], [-2.0, 3.1, -5.0, 0.01, 12.0]] {
        let v = tape.eval_f64(&point)[0];
        let r = g.eval_f64(p.root, &point);
        assert!(
            v.to_bits() == r.to_bits() || (v.is_nan() && r.is_nan()) || v == r,
            "tape {v} vs graph {r} at {point:?}"
        );
        let inputs: Vec<Dual<5>> = point.iter().enumerate().map(|(i, &x)| Dual::var(x, i)).collect();
        let mut regs = vec![Dual::<5>::cst(0.0); tape.n_regs()];
        tape.eval(&inputs, &mut regs);
        let d = regs[tape.outputs()[0] as usize].re();
        assert!(d == v || (d.is_nan() && v.is_nan()), "dual value {d} vs f64 {v} at {point:?}");
    }
}
/// An error message must name `label` (the file or spec it is about) and be words, not a
/// Rust `Debug` dump or a bare OS error number.
fn check_named(what: &str, label: &str, msg: &str) {
    check_message(what, msg);
    assert!(msg.contains(label), "{what}: error does not name {label}: {msg}");
    for debug in ["Some(", "None", "Err(", "Ok(", " { ", "os error"] {
        assert!(!msg.contains(debug), "{what}: error with Rust debug text `{debug}`: {msg}");
    }
}

/// The file name fuzzed `.mat` bytes are parsed under.
const MAT_FILE: &str = "fuzz.mat";

/// `.mat` files (`ssm::mat::MatFile::parse`, every variable's `get`, then SSMLearn's
/// trajectory layout `ssm::data::mat_trajectories`). Input: the file's bytes when they start
/// with `M` (the header's text), else the bytes after a valid v5 little-endian header (so
/// mutations reach the data elements). An error names the file and is words; an accepted
/// value has exactly the elements its dimensions say, cells nested at most
/// [`ssm::limits::MAX_MAT_DEPTH`] deep and at most [`ssm::limits::MAX_MATRIX_ENTRIES`]
/// entries; accepted trajectories validate.
pub fn mat_file(data: &[u8]) {
    let bytes: Vec<u8> = if data.first() == Some(&b'M') {
        data.to_vec()
    } else {
        let mut b = b"MATLAB 5.0 MAT-file, fuzz".to_vec();
        b.resize(124, b' ');
        b.extend_from_slice(&0x0100u16.to_le_bytes());
        b.extend_from_slice(b"IM");
        b.extend_from_slice(data);
        b
    };
    let m = match ssm::mat::MatFile::parse(MAT_FILE, &bytes) {
        Ok(m) => m,
        Err(e) => return check_named("mat", MAT_FILE, &e.to_string()),
    };
    let names: Vec<String> = m.names().iter().map(|s| s.to_string()).collect();
    for name in names.iter().take(4) {
        match m.get(name) {
            Ok(v) => {
                let entries = mat_shape_ok(&v, 0);
                assert!(entries <= ssm::limits::MAX_MATRIX_ENTRIES, "{entries} entries accepted");
                match ssm::data::mat_trajectories(MAT_FILE, name, &v) {
                    Ok(ts) => {
                        for t in &ts {
                            assert_eq!(t.validate().map_err(|e| e.to_string()), Ok(()), "accepted trajectory");
                            check_series(&t.t, &t.x);
                        }
                    }
                    Err(e) => check_named("mat layout", MAT_FILE, &e.to_string()),
                }
            }
            Err(e) => check_named("mat get", MAT_FILE, &e.to_string()),
        }
    }
}

/// Checks that every array of `v` has the elements its dimensions say; returns the entries.
fn mat_shape_ok(v: &ssm::mat::MatValue, depth: usize) -> usize {
    use ssm::mat::MatValue;
    assert!(depth <= ssm::limits::MAX_MAT_DEPTH, "cells nested {depth} deep accepted");
    match v {
        MatValue::Double { dims, data } => {
            assert_eq!(dims[0] * dims[1], data.len(), "a {dims:?} double array with {} values", data.len());
            data.len()
        }
        MatValue::Cell { dims, cells } => {
            assert_eq!(dims[0] * dims[1], cells.len(), "a {dims:?} cell with {} elements", cells.len());
            cells.iter().map(|c| mat_shape_ok(c, depth + 1)).sum::<usize>() + cells.len()
        }
    }
}

/// The label fuzzed sweep specs are parsed under.
const SPEC_LABEL: &str = "fuzz-spec.toml";

/// Sweep specs (`furuta::sweep::Sweep::parse`: TOML, the scene with its `set` overrides,
/// axes, records, basin settings). Input: the TOML text. An error names the spec; an
/// accepted sweep has a safe name, at most `MAX_CELLS` cells with every axis's values
/// present, passes the check a shard file's embedded spec gets (its grid recomputed from
/// its parts), and survives the JSON round trip shard files make, hash included.
pub fn sweep_spec(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let dir = std::env::temp_dir().join("fuzz-sweep-spec-no-such-dir");
    let s = match furuta::sweep::Sweep::parse(SPEC_LABEL, &text, &dir) {
        Ok(s) => s,
        Err(e) => return check_named("sweep spec", SPEC_LABEL, &e.to_string()),
    };
    assert!(sim::scene::check_name(&s.name).is_ok(), "accepted sweep name {:?} is not a safe file name", s.name);
    assert!(s.cells() >= 1 && s.cells() <= furuta::sweep::MAX_CELLS, "{} cells accepted", s.cells());
    for a in &s.axes {
        if let Some(r) = a.range {
            assert_eq!(a.values.len(), r.n, "axis {} of {} values for n = {}", a.name.as_str(), a.values.len(), r.n);
        }
    }
    if let Err(e) = s.check_embedded("fuzz") {
        panic!("an accepted spec fails the shard file's check of its own spec: {e}");
    }
    let json = serde_json::to_string(&s).unwrap_or_else(|e| panic!("accepted sweep does not serialize: {e}"));
    let back: furuta::sweep::Sweep =
        serde_json::from_str(&json).unwrap_or_else(|e| panic!("accepted sweep, serialized, is refused: {e}"));
    assert_eq!(back.hash().ok(), s.hash().ok(), "the spec hash changed in a JSON round trip");
}

/// The label fuzzed shard files are parsed under.
const SHARD_LABEL: &str = "shard-fuzz.json";

/// Sweep shard files (`ShardFile::parse`, then `merge` when the file is a whole run).
/// Input: JSON text (starting with `{` or white space), or else edits of a bundled shard
/// file (the first byte picks it, then 8-byte records as in [`model_json`]). An error names
/// the file; an accepted file's embedded spec passes its own check, its cells are its
/// shard's with their grid values, and a merged whole run has one cell per grid point, a
/// safe name and a CSV row per cell.
pub fn shard_file(data: &[u8]) {
    let text = match data.first() {
        Some(b'{' | b' ' | b'\n' | b'\t' | b'\r') | None => String::from_utf8_lossy(data).into_owned(),
        Some(&pick) => {
            let base = SHARDS[usize::from(pick) % SHARDS.len()];
            let mut v: serde_json::Value =
                serde_json::from_str(base).unwrap_or_else(|e| panic!("bundled seed shard: {e}"));
            for rec in data[1..].chunks_exact(8) {
                edit_model(&mut v, rec);
            }
            v.to_string()
        }
    };
    use furuta::sweep::shard::{ShardFile, merge};
    let f = match ShardFile::parse(SHARD_LABEL, &text) {
        Ok(f) => f,
        Err(e) => return check_named("shard", SHARD_LABEL, &e.to_string()),
    };
    if let Err(e) = f.spec.check_embedded(SHARD_LABEL) {
        panic!("an accepted shard's spec fails its check: {e}");
    }
    assert!(sim::scene::check_name(&f.spec.name).is_ok(), "accepted shard spec name {:?}", f.spec.name);
    let count = f.shard.count;
    match merge(vec![(SHARD_LABEL.to_string(), f)]) {
        Ok((r, _)) => {
            assert_eq!(count, 1, "a merge of one shard of {count}");
            assert_eq!(r.cells.len() as u64, r.spec.cells(), "merged cells");
            for (k, c) in r.cells.iter().enumerate() {
                assert_eq!(c.index, k as u64, "merged cell order");
            }
            assert_eq!(r.to_csv().lines().count(), r.cells.len() + 1, "CSV rows");
        }
        Err(e) => check_message("merge", &e.to_string()),
    }
}

/// Shard files the structure-aware mode of [`shard_file`] edits (its seeds).
const SHARDS: [&str; 2] =
    [include_str!("../../fuzz/seeds/shard_file/chart-whole"), include_str!("../../fuzz/seeds/shard_file/basin-whole")];
