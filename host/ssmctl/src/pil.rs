//! Processor-in-the-loop: the plant of a scene simulated here, the integer controller and the
//! RBF predictor running on the Cortex-M4F under QEMU (`qemu/src/bin/pil.rs`), joined by
//! UART0 over TCP. Every period the host sends the encoder counts and the measured primary
//! angle (`q_theta * h_adc`, the angle the counts stand for: all a device can know), the
//! device answers with the DAC code and a one-step prediction, and the code is held over the
//! next period. A host-side [`IntPd`] and f32 [`Predictor`] fed the same inputs check the
//! device's answers (codes and prediction bits); after the run, the host-only simulation of
//! the same scene ([`sim::closed_loop::simulate_plant`], same seed) checks the whole closed loop:
//! its codes and states must equal the PIL run's.
//!
//! The run is recorded as a data set: `theta.csv` (`t_s,theta_meas_rad`, the measured primary
//! angle as the controller saw it: sensor noise added, then encoder quantization; the format
//! of the measured data sets, loadable with [`ssm::data::load_csv`]) and `record.csv`
//! (`t_s,theta_rad,phi_rad,theta_meas_rad,code,prediction`: true plant angles, measured
//! angle, the device's DAC code and its `predict(1)`, `NaN` until the window is full; for a
//! plant with one coordinate `phi_rad` is the primary coordinate's velocity, the plant's
//! `SECONDARY` state component).
//!
//! Sensor semantics are those of [`sim::closed_loop::simulate_with`]: the same noise draws (ChaCha8
//! with the scene's seed, primary then secondary), the same `adc` rounding, the same
//! constant pre-history. Scenes must use `counts` quantization; a scene with an explicit
//! `initial.history` is refused (the device primes from one constant pair).
//!
//! Frame layout, kinds and fault codes: [`shared::frame`].

use controller::IntPd;
use controller::predictor::{Predictor, SqrtFlavour};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;
use shared::frame::{
    self, Fault, FrameError, HEADER_LEN, Header, Kind, LoadReply, MAX_FRAME, REPLY_START, Seq, StepReply,
};
use sim::closed_loop::{AnyPlant, HISTORY, SimError, Stepper, build_plant};
use sim::plant::Plant;
use sim::scene::{Scene, SceneError};
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::output::AtomicFile;

/// The firmware's predictor capacities (`qemu/src/bin/pil.rs` uses the same).
pub type PilPredictor = Predictor<16, 6, 256, 84, 64>;

#[derive(Debug, thiserror::Error)]
pub enum PilError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Sim(#[from] SimError),
    #[error("scene {0}: PIL needs `effects.quantization.mode = \"counts\"`")]
    NotCounts(String),
    #[error(
        "scene {0}: an explicit initial.history is not supported by PIL (the device primes from one constant pair)"
    )]
    History(String),
    #[error(
        "the model blob's controller configuration differs from scene {scene}'s:\n  blob:  {blob}\n  scene: {scene_cfg}"
    )]
    ConfigMismatch { scene: String, blob: String, scene_cfg: String },
    #[error("model blob: {0}")]
    Blob(String),
    #[error("{0}")]
    Options(String),
    #[error("{what}: {}", infile::describe(.source))]
    Io { what: String, source: std::io::Error },
    #[error("QEMU: {0}")]
    Qemu(String),
    #[error("link, frame {seq}: {what}")]
    Link { seq: u16, what: String },
    #[error("device refused frame {seq} (kind {kind}): {fault}")]
    Device { seq: u16, kind: u8, fault: &'static str },
    #[error("model fit: {0}")]
    Fit(String),
    #[error("t = {t}: {message}")]
    Sensor { t: f64, message: String },
    #[error("host-only simulation for the comparison: {0}")]
    HostSim(String),
}

fn io(what: impl Into<String>) -> impl FnOnce(std::io::Error) -> PilError {
    let what = what.into();
    move |source| PilError::Io { what, source }
}

/// A frame ready to send: [`frame::encode`] into a buffer of the largest frame's size.
pub struct Outgoing {
    buf: [u8; MAX_FRAME],
    len: usize,
}

impl Outgoing {
    /// The frame of `kind`, `seq` and `payload`; an error names the frame when it does not fit.
    pub fn new(kind: Kind, seq: Seq, payload: &[u8]) -> Result<Self, PilError> {
        let mut buf = [0u8; MAX_FRAME];
        let len = frame::encode(kind, seq, payload, &mut buf)
            .map_err(|e| PilError::Link { seq: seq.0, what: e.to_string() })?;
        Ok(Outgoing { buf, len })
    }

    /// The encoded frame, header to CRC.
    pub fn bytes(&self) -> &[u8] {
        &self.buf[..self.len]
    }
}

fn fault_name(code: u8) -> &'static str {
    Fault::from_code(code).map_or("unknown fault code", Fault::description)
}

/// The QEMU machine of a PIL run: each runs the firmware built for its board.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Machine {
    /// `mps2-an386` (Cortex-M4F): the default build, CMSDK UART0.
    #[default]
    Mps2An386,
    /// `netduinoplus2` (STM32F405): the `stm32f407` build (same memory map), USART1.
    Netduinoplus2,
}

impl Machine {
    /// QEMU's name of the machine.
    pub fn name(self) -> &'static str {
        match self {
            Self::Mps2An386 => "mps2-an386",
            Self::Netduinoplus2 => "netduinoplus2",
        }
    }

    /// Parses QEMU's name of the machine.
    pub fn parse(name: &str) -> Result<Self, String> {
        match name {
            "mps2-an386" => Ok(Self::Mps2An386),
            "netduinoplus2" => Ok(Self::Netduinoplus2),
            other => Err(format!("unknown machine `{other}` (expected mps2-an386 or netduinoplus2)")),
        }
    }

    /// QEMU's machine and CPU options.
    fn qemu_args(self) -> &'static [&'static str] {
        match self {
            Self::Mps2An386 => &["-cpu", "cortex-m4", "-machine", "mps2-an386"],
            Self::Netduinoplus2 => &["-machine", "netduinoplus2"],
        }
    }
}

/// Options of one PIL run.
#[derive(Clone, Debug)]
pub struct PilOptions {
    pub scene: String,
    pub overrides: Vec<String>,
    pub model: PathBuf,
    pub periods: u64,
    pub out: PathBuf,
    /// The firmware's `pil` ELF.
    pub elf: PathBuf,
    /// The QEMU machine it runs in (the ELF must be built for it).
    pub machine: Machine,
    /// Per-reply limit.
    pub reply_timeout: Duration,
}

/// What a run measured (also written as `summary.json`).
#[derive(Clone, Debug, Serialize)]
pub struct PilSummary {
    pub scene: String,
    pub periods: u64,
    /// Encoder counts per period (the controller's measured coordinates).
    pub measured_coordinates: usize,
    pub codes_identical: bool,
    pub first_code_mismatch: Option<u64>,
    pub predictions_compared: u64,
    pub predictions_bit_identical: bool,
    pub max_pred_rel_diff: f64,
    pub saturated_samples: u64,
    /// Step requests answered per second of time spent on the link (send to reply).
    pub round_trips_per_s: f64,
    /// Periods per second of the whole loop (plant integration included).
    pub periods_per_s: f64,
    pub error_frames_checked: bool,
    pub stopped: Option<String>,
    /// The scene's sensor noise (`None`: noiseless run).
    pub noise: Option<sim::scene::NoiseSpec>,
    /// What `theta.csv` holds.
    pub observable: String,
    /// Whether the host-only simulation of the scene (same seed,
    /// [`sim::closed_loop::simulate_plant`]) produced the same encoder counts and DAC codes
    /// as the PIL run, period by period.
    pub host_sim_codes_identical: bool,
    pub host_sim_first_mismatch: Option<u64>,
    /// Largest |state difference| between the PIL run and the host-only simulation (0 when
    /// the codes agree: the plant integration is the same code on the same inputs).
    pub host_sim_max_state_diff: f64,
}

impl PilSummary {
    /// A summary before the first period: nothing compared yet, every flag still true, the
    /// host-only comparison not yet made (state difference infinite).
    pub fn initial(scene: String, noise: Option<sim::scene::NoiseSpec>, observable: String) -> Self {
        PilSummary {
            scene,
            periods: 0,
            measured_coordinates: 0,
            codes_identical: true,
            first_code_mismatch: None,
            predictions_compared: 0,
            predictions_bit_identical: true,
            max_pred_rel_diff: 0.0,
            saturated_samples: 0,
            round_trips_per_s: 0.0,
            periods_per_s: 0.0,
            error_frames_checked: true,
            stopped: None,
            noise,
            observable,
            host_sim_codes_identical: false,
            host_sim_first_mismatch: None,
            host_sim_max_state_diff: f64::INFINITY,
        }
    }
}

/// Header of `theta.csv`.
pub const THETA_HEADER: &str = "t_s,theta_meas_rad";
/// Header of `record.csv`.
pub const RECORD_HEADER: &str = "t_s,theta_rad,phi_rad,theta_meas_rad,code,prediction";

/// One period of the recorded data set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RecordRow {
    pub t: f64,
    /// True plant angles at the sample.
    pub theta: f64,
    pub phi: f64,
    /// The measured primary angle the controller saw: `q_theta * h_adc`.
    pub theta_meas: f64,
    /// The device's DAC code.
    pub code: i32,
    /// The device's `predict(1)`, `None` until its window is full (written `NaN`).
    pub prediction: Option<f32>,
}

/// Writes `theta.csv` and `record.csv` row by row (values printed in Rust's shortest
/// round-trip form, so loading gives back the same bits). Both are temporary files until
/// [`Recorder::finish`]: a failed run leaves no partial data set (see [`crate::output`]).
pub struct Recorder {
    theta: AtomicFile,
    record: AtomicFile,
    theta_path: PathBuf,
    record_path: PathBuf,
}

/// Largest `--timeout` accepted, seconds.
pub const MAX_REPLY_TIMEOUT_S: f64 = 3600.0;

/// The per-reply timeout of `--timeout SECONDS`, range-checked before it becomes a
/// `Duration` (which panics on huge values).
pub fn reply_timeout(secs: f64) -> Result<Duration, String> {
    if secs.is_finite() && secs > 0.0 && secs <= MAX_REPLY_TIMEOUT_S {
        Ok(Duration::from_secs_f64(secs))
    } else {
        Err(format!("--timeout must be a number of seconds in (0, {MAX_REPLY_TIMEOUT_S}], got {secs}"))
    }
}

impl Recorder {
    /// Starts `dir/theta.csv` and `dir/record.csv` (the folder must exist) with headers.
    pub fn create(dir: &Path) -> Result<Self, PilError> {
        let theta_path = dir.join("theta.csv");
        let record_path = dir.join("record.csv");
        let open = |p: &Path| -> Result<AtomicFile, PilError> {
            AtomicFile::create(p).map_err(io(format!("creating {}", p.display())))
        };
        let mut r = Recorder { theta: open(&theta_path)?, record: open(&record_path)?, theta_path, record_path };
        writeln!(r.theta, "{THETA_HEADER}").map_err(io(r.theta_path.display().to_string()))?;
        writeln!(r.record, "{RECORD_HEADER}").map_err(io(r.record_path.display().to_string()))?;
        Ok(r)
    }

    pub fn row(&mut self, r: &RecordRow) -> Result<(), PilError> {
        writeln!(self.theta, "{},{}", r.t, r.theta_meas).map_err(io(self.theta_path.display().to_string()))?;
        let pred = r.prediction.map_or_else(|| "NaN".to_string(), |p| p.to_string());
        writeln!(self.record, "{},{},{},{},{},{pred}", r.t, r.theta, r.phi, r.theta_meas, r.code)
            .map_err(io(self.record_path.display().to_string()))
    }

    /// Completes both files (renames them into place).
    pub fn finish(self) -> Result<(), PilError> {
        self.theta.commit().map_err(io(self.theta_path.display().to_string()))?;
        self.record.commit().map_err(io(self.record_path.display().to_string()))
    }
}

/// The host's end of the frame link to the device: the socket and the next request's sequence
/// number.
pub struct Link {
    /// The socket to the device (QEMU's serial port), with its read timeout set.
    pub stream: TcpStream,
    /// The sequence number of the next request.
    pub seq: Seq,
}

impl Link {
    /// Sends a request of `kind` (a request kind) and returns the device's successful reply.
    pub fn transact(&mut self, kind: Kind, payload: &[u8]) -> Result<(Kind, Vec<u8>), PilError> {
        let seq = self.seq;
        self.seq = self.seq.next();
        self.send_raw(Outgoing::new(kind, seq, payload)?.bytes(), seq.0)?;
        let (rk, rseq, p) = self.receive(seq.0)?;
        let (seq, code) = (seq.0, kind.code());
        if rseq.0 != seq {
            return Err(PilError::Link {
                seq,
                what: format!("reply carries sequence number {rseq} (a frame was lost or duplicated)"),
            });
        }
        if rk == Kind::Error {
            return Err(PilError::Device { seq, kind: code, fault: fault_name(p.first().copied().unwrap_or(0)) });
        }
        let Some(want) = kind.success_reply() else {
            return Err(PilError::Link { seq, what: format!("kind {code:#x} is not a request") });
        };
        if rk != want {
            let (rk, want) = (rk.code(), want.code());
            return Err(PilError::Link {
                seq,
                what: format!("reply of kind {rk:#x} to a request of kind {code}, expected {want:#x}"),
            });
        }
        Ok((rk, p))
    }

    /// Waits for the device's hello (an empty ack numbered 0xFFFF, sent once its serial port
    /// is enabled): a request sent earlier could be lost (the STM32's USART drops bytes
    /// received before it is enabled).
    pub fn hello(&mut self) -> Result<(), PilError> {
        let (k, s, p) = self.receive(u16::MAX)?;
        if (k, s, p.as_slice()) != (Kind::Ack, Seq(u16::MAX), &[][..]) {
            let k = k.code();
            return Err(PilError::Link {
                seq: u16::MAX,
                what: format!(
                    "the device's first frame is kind {k:#x} seq {s} payload {p:?}, not the hello (empty ack numbered 65535)"
                ),
            });
        }
        Ok(())
    }

    fn send_raw(&mut self, frame: &[u8], seq: u16) -> Result<(), PilError> {
        self.stream.write_all(frame).map_err(|e| PilError::Link { seq, what: format!("send failed: {e}") })
    }

    fn read_exact(&mut self, buf: &mut [u8], seq: u16) -> Result<(), PilError> {
        self.stream.read_exact(buf).map_err(|e| {
            let what = match e.kind() {
                std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut => {
                    "no reply within the timeout (device hung or frame lost)".to_string()
                }
                std::io::ErrorKind::UnexpectedEof => "the device closed the link (QEMU exited?)".to_string(),
                _ => format!("receive failed: {e}"),
            };
            PilError::Link { seq, what }
        })
    }

    /// One reply frame: (kind, seq, payload), CRC and kind checked ([`frame::decode`]).
    fn receive(&mut self, seq: u16) -> Result<(Kind, Seq, Vec<u8>), PilError> {
        let mut buf = [0u8; MAX_FRAME];
        self.read_exact(&mut buf[..1], seq)?;
        if buf[0] != REPLY_START {
            return Err(PilError::Link {
                seq,
                what: format!("reply starts with byte {:#04x}, not {REPLY_START:#04x} (corrupt stream)", buf[0]),
            });
        }
        self.read_exact(&mut buf[1..HEADER_LEN], seq)?;
        let n = Header::parse(&buf).map_err(|e| PilError::Link { seq, what: format!("reply: {e}") })?.frame_len();
        self.read_exact(&mut buf[HEADER_LEN..n], seq)?;
        match frame::decode(&buf[..n]) {
            Ok(f) => Ok((f.kind, f.seq, f.payload.to_vec())),
            Err(FrameError::Crc { stated, computed, .. }) => Err(PilError::Link {
                seq,
                what: format!("reply CRC {stated:#010x} != computed {computed:#010x} (corrupt frame)"),
            }),
            Err(e) => Err(PilError::Link { seq, what: format!("reply: {e}") }),
        }
    }

    /// The device must answer a corrupt frame and a frame out of sequence with the matching
    /// error, and change nothing (the sequence continues).
    fn check_error_paths(&mut self) -> Result<(), PilError> {
        let seq = self.seq;
        let mut bad = Outgoing::new(Kind::Prime, seq, &[0; 8])?;
        bad.buf[6] ^= 0x40;
        self.send_raw(bad.bytes(), seq.0)?;
        let (k, s, p) = self.receive(seq.0)?;
        if (k, s, p.as_slice()) != (Kind::Error, seq, &[Fault::Crc.code()][..]) {
            let k = k.code();
            return Err(PilError::Link {
                seq: seq.0,
                what: format!("a corrupted frame got reply kind {k:#x} seq {s} payload {p:?}, not a CRC error"),
            });
        }
        let ahead = Seq(seq.0.wrapping_add(7));
        self.send_raw(Outgoing::new(Kind::Prime, ahead, &[0; 8])?.bytes(), ahead.0)?;
        let (k, s, p) = self.receive(ahead.0)?;
        if (k, s, p.as_slice()) != (Kind::Error, ahead, &[Fault::Seq.code()][..]) {
            let k = k.code();
            return Err(PilError::Link {
                seq: seq.0,
                what: format!(
                    "an out-of-sequence frame got reply kind {k:#x} seq {s} payload {p:?}, not a sequence error"
                ),
            });
        }
        Ok(())
    }
}

/// QEMU's program: `qemu-system-arm`, or the path in `SSMCTL_QEMU` (another build of QEMU;
/// the tests use it to put a stand-in child in QEMU's place).
fn qemu_program() -> std::ffi::OsString {
    std::env::var_os("SSMCTL_QEMU").unwrap_or_else(|| "qemu-system-arm".into())
}

/// Checks that `elf` is ARM firmware (a 32-bit little-endian ELF image for machine ARM)
/// before QEMU is asked to boot it; `log` is where QEMU's own messages go.
fn check_firmware(elf: &Path, log: &Path) -> Result<(), PilError> {
    let head = infile::read_prefix(elf, 20).map_err(|e| {
        let hint = if e.kind() == std::io::ErrorKind::NotFound {
            ": build it with `cargo xtask pil` (or `cargo build --release --bin pil` in qemu/)"
        } else {
            ""
        };
        PilError::Options(format!("--elf {}: cannot read: {e}{hint}", elf.display()))
    })?;
    let what = match head.as_slice() {
        [0x7f, b'E', b'L', b'F', 1, 1, _, _, _, _, _, _, _, _, _, _, _, _, 40, 0] => return Ok(()),
        [0x7f, b'E', b'L', b'F', ..] if head.len() < 20 => "a truncated ELF file",
        [0x7f, b'E', b'L', b'F', 2, ..] => "a 64-bit ELF file (a host program?)",
        [0x7f, b'E', b'L', b'F', ..] => "an ELF file for another machine than 32-bit little-endian ARM",
        [] => "an empty file",
        _ => "not an ELF file",
    };
    Err(PilError::Options(format!(
        "--elf {}: {what}, not the firmware; build it with `cargo xtask pil` (QEMU's messages go to {})",
        elf.display(),
        log.display()
    )))
}

fn start(elf: &Path, machine: Machine, out: &Path) -> Result<(crate::child::Tied, TcpStream), PilError> {
    let listener = TcpListener::bind("127.0.0.1:0").map_err(io("bind 127.0.0.1:0"))?;
    let port = listener.local_addr().map_err(io("local address"))?.port();
    let log_path = out.join("qemu.log");
    let log = crate::output::open_log(&log_path).map_err(|e| PilError::Options(e.to_string()))?;
    let program = qemu_program();
    // Tied: QEMU dies with ssmctl whatever ends it (signals included) and is killed and
    // reaped when the run returns (`crate::child`).
    let mut qemu = crate::child::spawn_tied(
        Command::new(&program)
            .args(machine.qemu_args())
            .args(["-nographic", "-monitor", "none"])
            .args(["-semihosting-config", "enable=on,target=native"])
            .arg("-serial")
            .arg(format!("tcp:127.0.0.1:{port},nodelay=on"))
            .arg("-kernel")
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(log.try_clone().map_err(io("log"))?)
            .stderr(log),
    )
    .map_err(|e| {
        PilError::Qemu(format!("cannot start {} (run `cargo xtask install`): {e}", program.to_string_lossy()))
    })?;
    listener.set_nonblocking(true).map_err(io("listener"))?;
    let t0 = Instant::now();
    let stream = loop {
        match listener.accept() {
            Ok((s, _)) => break s,
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                if let Ok(Some(st)) = qemu.0.try_wait() {
                    return Err(PilError::Qemu(format!(
                        "exited with {st} before connecting (see {})",
                        log_path.display()
                    )));
                }
                if t0.elapsed() > Duration::from_secs(10) {
                    return Err(PilError::Qemu(format!(
                        "did not connect to the UART socket within 10 s (see {})",
                        log_path.display()
                    )));
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            Err(e) => return Err(io("accept")(e)),
        }
    };
    stream.set_nonblocking(false).map_err(io("socket"))?;
    stream.set_nodelay(true).map_err(io("TCP_NODELAY"))?;
    Ok((qemu, stream))
}

/// Fits a 4D RBF SSM model of the scene's primary angle (1,200 simulated periods) and
/// returns the device blob carrying the scene's controller configuration.
pub fn fit_model(scene: &Scene) -> Result<Vec<u8>, PilError> {
    let (m, _) = furuta::device_model::fit_scene_rbf(scene, 1200).map_err(|e| PilError::Fit(e.to_string()))?;
    let owned =
        ssm::device::to_device_model(&m, scene.controller_config()).map_err(|e| PilError::Fit(e.to_string()))?;
    ssm::device::encode(&owned).map_err(|e| PilError::Fit(e.to_string()))
}

/// Runs the loop; writes `pil.csv`, `theta.csv`, `record.csv` and `summary.json` into
/// `opts.out`.
pub fn run(opts: &PilOptions) -> Result<PilSummary, PilError> {
    if opts.periods == 0 || opts.periods > sim::scene::MAX_PERIODS {
        return Err(PilError::Options(format!(
            "periods must be in 1..={}, got {}",
            sim::scene::MAX_PERIODS,
            opts.periods
        )));
    }
    check_firmware(&opts.elf, &opts.out.join("qemu.log"))?;
    let scene = Scene::load(&opts.scene, &opts.overrides)?;
    // The plant, built once, integrated through `Stepper` and simulated by `simulate_plant`,
    // whose numerics `sim` compiles: this loop's own code is glue, generic over the plant only
    // for its state array and names.
    let plant = build_plant(&scene)?;
    let stepper = Stepper::with_plant(&scene, plant.clone())?;
    sim::with_plant!(&plant, p => run_with(p, &plant, stepper, &scene, opts))
}

/// The PIL loop on `plant`, the concrete plant inside `any`.
fn run_with<P: Plant<N>, const N: usize>(
    plant: &P,
    any: &AnyPlant,
    mut stepper: Stepper,
    scene: &Scene,
    opts: &PilOptions,
) -> Result<PilSummary, PilError> {
    let name = scene.name.clone();
    let cfg = scene.controller_config();
    match cfg.quant {
        Some(q) if q.mode == shared::QuantMode::Counts => {}
        _ => return Err(PilError::NotCounts(name)),
    }
    if scene.initial.history.is_some() {
        return Err(PilError::History(name));
    }
    let outputs = ["pil.csv", "theta.csv", "record.csv", "summary.json"].map(|f| opts.out.join(f));
    let scene_file = PathBuf::from(&opts.scene);
    for o in &outputs {
        crate::output::check_not_input(o, &[("--model", &opts.model), ("--scene", &scene_file), ("--elf", &opts.elf)])
            .map_err(|e| PilError::Options(e.to_string()))?;
    }
    let blob = infile::read_bytes(&opts.model, infile::MAX_BLOB_BYTES)
        .map_err(io(format!("--model {}: cannot read", opts.model.display())))?;
    let mut pred = Box::new(PilPredictor::empty(SqrtFlavour::Libm));
    pred.load(&blob).map_err(|e| PilError::Blob(format!("{}: {e}", opts.model.display())))?;
    if *pred.model().config() != cfg {
        return Err(PilError::ConfigMismatch {
            scene: name,
            blob: format!("{:?}", pred.model().config()),
            scene_cfg: format!("{cfg:?}"),
        });
    }
    // The predictor runs one step per controller period: the model must be sampled at it.
    ssm::device::check_loop_dt(f64::from(pred.model().sample_period()), cfg.dt)
        .map_err(|e| PilError::Blob(format!("{}: {e}", opts.model.display())))?;
    let mut pd =
        IntPd::<HISTORY>::try_new(&cfg).map_err(|e| PilError::Blob(format!("controller configuration: {e}")))?;

    let mut x = [0.0; N];
    if !scene.initial.state.is_empty() {
        if scene.initial.state.len() != N {
            return Err(SimError::StateLength {
                scene: name,
                plant: plant.name(),
                got: scene.initial.state.len(),
                need: N,
            }
            .into());
        }
        x.copy_from_slice(&scene.initial.state);
    }
    let sensor = |t: f64, what: &str, v: f64, e: controller::AdcError| PilError::Sensor {
        t,
        message: format!("{what} {v}: {e}"),
    };
    // The measured coordinates (state indices) and their encoder resolutions, in gain order.
    let idx = sim::closed_loop::measured_indices(&cfg, N, &name)?;
    let h: Vec<f64> = cfg.gains.iter().map(|g| g.h_adc).collect();
    let what = |j: usize, pre: bool| {
        let c = match j {
            0 => "primary angle".to_string(),
            1 => "secondary angle".to_string(),
            _ => format!("measured coordinate {j}"),
        };
        if pre { format!("pre-history {c}") } else { c }
    };
    let counts_at = |t: f64, y: &[f64], pre: bool| -> Result<Vec<i32>, PilError> {
        y.iter()
            .zip(&h)
            .enumerate()
            .map(|(j, (&v, &hj))| controller::adc(v, hj).map_err(|e| sensor(t, &what(j, pre), v, e)))
            .collect()
    };
    let q0 = counts_at(0.0, &idx.iter().map(|&i| x[i]).collect::<Vec<_>>(), true)?;
    pd.prime_constant(&q0).map_err(|e| PilError::Blob(format!("controller: {e}")))?;
    let mut noise = match &scene.effects.noise {
        Some(n) => {
            if idx.len() > 2 {
                return Err(PilError::Fit(format!(
                    "effects.noise gives sigma_theta and sigma_phi (two measured coordinates), the controller measures {}",
                    idx.len()
                )));
            }
            let normal = |sigma: f64| Normal::new(0.0, sigma).map_err(|e| PilError::Fit(format!("noise: {e}")));
            Some((ChaCha8Rng::seed_from_u64(n.seed), [normal(n.sigma_theta)?, normal(n.sigma_phi)?]))
        }
        None => None,
    };
    crate::output::create_dir(&opts.out).map_err(|e| PilError::Options(e.to_string()))?;
    let (mut qemu, stream) = start(&opts.elf, opts.machine, &opts.out)?;
    stream.set_read_timeout(Some(opts.reply_timeout)).map_err(io("read timeout"))?;
    let mut link = Link { stream, seq: Seq(0) };
    link.hello()?;
    for chunk in blob.chunks(240) {
        link.transact(Kind::ModelChunk, chunk)?;
    }
    let (_, load) = link.transact(Kind::Load, &[])?;
    let want = LoadReply { delay: pd.delay().min(255) as u8, coordinates: pd.coordinates() as u8 };
    match LoadReply::decode(&load) {
        Ok(r) if r == want => {}
        got => {
            return Err(PilError::Link {
                seq: link.seq.0.wrapping_sub(1),
                what: format!(
                    "device reports {got:?} for the loaded controller, host delay {} and {} coordinates",
                    pd.delay(),
                    pd.coordinates()
                ),
            });
        }
    }
    link.check_error_paths()?;
    let counts = |c: &[i32]| frame::Counts::new(c).map_err(|e| PilError::Blob(format!("controller counts: {e}")));
    let mut p = [0u8; frame::Prime::MAX_LEN];
    let n = frame::Prime(counts(&q0)?).encode(&mut p).map_err(|e| PilError::Blob(e.to_string()))?;
    link.transact(Kind::Prime, &p[..n])?;

    let csv_path = opts.out.join("pil.csv");
    let mut csv = AtomicFile::create(&csv_path).map_err(io(csv_path.display().to_string()))?;
    let wr = |e| io(csv_path.display().to_string())(e);
    // The two recorded state components under the plant's own names (the Furuta's `theta`,
    // `phi`; a one-coordinate plant's second column is its velocity).
    let names = plant.state_names();
    let (n0, n1) = (names.get(P::PRIMARY).copied().unwrap_or("?"), names.get(P::SECONDARY).copied().unwrap_or("?"));
    writeln!(csv, "t,{n0},{n1},q_theta,q_phi,code,code_host,saturated,ready,prediction,prediction_host").map_err(wr)?;
    let mut rec = Recorder::create(&opts.out)?;
    // What the PIL loop produced, for the comparison with the host-only simulation.
    let mut run_codes: Vec<sim::closed_loop::Codes> = Vec::new();
    let mut run_states: Vec<[f64; N]> = Vec::new();
    let observable = format!(
        "theta.csv: measured primary angle q_theta * h_adc (h_adc = {} rad){}",
        h[0],
        scene.effects.noise.as_ref().map_or(String::new(), |n| format!(
            ", Gaussian sensor noise sigma {} rad (seed {}) added before the encoder",
            n.sigma_theta, n.seed
        ))
    );
    let mut s = PilSummary::initial(scene.name.clone(), scene.effects.noise.clone(), observable);
    s.measured_coordinates = idx.len();
    let dt = cfg.dt;
    let t_start = Instant::now();
    let mut link_secs = 0.0f64;
    for i in 0..opts.periods {
        let t = i as f64 * dt;
        // The measured coordinates, noise added in gain order (as the host simulation does).
        let mut y: Vec<f64> = idx.iter().map(|&i| x[i]).collect();
        if let Some((rng, normal)) = &mut noise {
            for (v, nd) in y.iter_mut().zip(normal.iter()) {
                *v += nd.sample(rng);
            }
        }
        let q = counts_at(t, &y, false)?;
        let (qy, qz) = (q[0], q.get(1).copied().unwrap_or(0));
        // The measured angle: what the counts stand for (the controller's own view).
        let theta_meas = f64::from(qy) * h[0];
        let sample = theta_meas as f32;
        let mut p = [0u8; frame::Step::MAX_LEN];
        let n =
            frame::Step { counts: counts(&q)?, sample }.encode(&mut p).map_err(|e| PilError::Blob(e.to_string()))?;
        let seq = link.seq.0;
        let t_rt = Instant::now();
        let (k, r) = link.transact(Kind::Step, &p[..n])?;
        link_secs += t_rt.elapsed().as_secs_f64();
        let reply = match (k, StepReply::decode(&r)) {
            (Kind::StepReply, Ok(reply)) => reply,
            (_, e) => {
                return Err(PilError::Link {
                    seq,
                    what: format!("step reply of kind {:#x} with {} bytes: {e:?}", k.code(), r.len()),
                });
            }
        };
        let StepReply { code, saturated, ready, prediction: dev_pred } = reply;
        let host = pd.step(&q).map_err(|e| PilError::Sensor { t, message: e.to_string() })?;
        let host_pred = pred.push(sample).and_then(|()| pred.predict(1)).ok();
        if host.code != code || host.saturated != saturated {
            s.codes_identical = false;
            s.first_code_mismatch.get_or_insert(i);
        }
        match (ready, host_pred) {
            (true, Some(h)) => {
                s.predictions_compared += 1;
                if h.to_bits() != dev_pred.to_bits() {
                    s.predictions_bit_identical = false;
                }
                let rel = f64::from((dev_pred - h).abs()) / f64::from(h.abs()).max(f64::from(f32::MIN_POSITIVE));
                let rel = if rel.is_nan() { f64::INFINITY } else { rel };
                s.max_pred_rel_diff = s.max_pred_rel_diff.max(rel);
            }
            (false, None) => {}
            _ => {
                s.predictions_bit_identical = false;
                s.max_pred_rel_diff = f64::INFINITY;
            }
        }
        s.saturated_samples += u64::from(saturated);
        let hp = host_pred.map_or(String::new(), |v| v.to_string());
        let dp = if ready { dev_pred.to_string() } else { String::new() };
        writeln!(
            csv,
            "{t},{},{},{qy},{qz},{code},{},{},{},{dp},{hp}",
            x[P::PRIMARY],
            x[P::SECONDARY],
            host.code,
            u8::from(saturated),
            u8::from(ready)
        )
        .map_err(wr)?;
        rec.row(&RecordRow {
            t,
            theta: x[P::PRIMARY],
            phi: x[P::SECONDARY],
            theta_meas,
            code,
            prediction: ready.then_some(dev_pred),
        })?;
        run_codes.push(sim::closed_loop::Codes {
            q_theta: qy,
            q_phi: qz,
            code,
            q_rest: core::array::from_fn(|k| q.get(k + 2).copied().unwrap_or(0)),
            measured: q.len() as u8,
        });
        run_states.push(x);
        s.periods = i + 1;
        if let Some(limit) = scene.run.escape_theta
            && x[P::PRIMARY].abs() > limit
        {
            s.stopped = Some(format!("|primary angle| exceeded {limit} rad at t = {t:.4} s"));
            break;
        }
        // The device's code is what the plant sees.
        let u = pd.volts(code);
        stepper.advance(&mut x, u, dt).map_err(|source| SimError::Ode { scene: name.clone(), source })?;
    }
    let secs = t_start.elapsed().as_secs_f64();
    s.round_trips_per_s = if link_secs > 0.0 { s.periods as f64 / link_secs } else { 0.0 };
    s.periods_per_s = if secs > 0.0 { s.periods as f64 / secs } else { 0.0 };
    link.transact(Kind::Shutdown, &[])?;
    let t0 = Instant::now();
    let status = loop {
        if let Some(st) = qemu.0.try_wait().map_err(io("waiting for QEMU"))? {
            break st;
        }
        if t0.elapsed() > Duration::from_secs(5) {
            return Err(PilError::Qemu("did not exit within 5 s of the shutdown frame".into()));
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    if !status.success() {
        return Err(PilError::Qemu(format!("exited with {status} after the shutdown frame")));
    }
    compare_with_host_sim(scene, any, &run_codes, &run_states, &mut s)?;
    let json = serde_json::to_string_pretty(&s).map_err(|e| PilError::Fit(e.to_string()))?;
    // Only a complete run becomes files.
    csv.commit().map_err(wr)?;
    rec.finish()?;
    let path = opts.out.join("summary.json");
    crate::output::write_atomic(&path, json.as_bytes()).map_err(io(path.display().to_string()))?;
    Ok(s)
}

/// Runs the host-only simulation of `scene` on its built `plant` ([`build_plant`] of `scene`)
/// over the PIL run's periods and compares codes (counts in, code out) and states with the
/// PIL run's, filling the `host_sim_*` fields.
pub fn compare_with_host_sim<const N: usize>(
    scene: &Scene,
    plant: &AnyPlant,
    codes: &[sim::closed_loop::Codes],
    states: &[[f64; N]],
    s: &mut PilSummary,
) -> Result<(), PilError> {
    let Some(last) = codes.len().checked_sub(1) else {
        return Ok(());
    };
    let mut sc = scene.clone();
    sc.run.periods = last as u64; // rows 0..=periods
    let tr = sim::closed_loop::simulate_plant(&sc, plant, None).map_err(|e| PilError::HostSim(e.to_string()))?;
    let sim_codes = tr.codes.as_deref().unwrap_or_default();
    let rows = tr.rows().min(sim_codes.len());
    s.host_sim_codes_identical = rows == codes.len();
    s.host_sim_first_mismatch = None;
    s.host_sim_max_state_diff = 0.0;
    for (i, (dev, x)) in codes.iter().zip(states).enumerate() {
        let (Some(sim), true) = (sim_codes.get(i), i < rows) else {
            s.host_sim_codes_identical = false;
            s.host_sim_first_mismatch.get_or_insert(i as u64);
            break;
        };
        if sim != dev {
            s.host_sim_codes_identical = false;
            s.host_sim_first_mismatch.get_or_insert(i as u64);
        }
        for (k, xk) in x.iter().enumerate() {
            let d = (tr.state(i, k) - xk).abs();
            s.host_sim_max_state_diff = s.host_sim_max_state_diff.max(if d.is_nan() { f64::INFINITY } else { d });
        }
    }
    Ok(())
}
