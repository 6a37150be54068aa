//! Processor-in-the-loop: the integer PD controller and the RBF predictor answer requests
//! from the host over the board's serial port (UART0 of mps2-an386, USART1 of the
//! STM32F4: [`board`]) (run by `ssmctl pil` / `cargo xtask pil`).
//!
//! Frames, kinds and fault codes: `shared::frame` (the host uses the same definition).
//! Request kinds: model chunk (appended to the blob buffer), load (decode the blob:
//! predictor + controller config; reply [`frame::LoadReply`]: delay and measured
//! coordinates), prime ([`frame::Prime`]: one count per coordinate), step ([`frame::Step`]:
//! the counts and the predictor's sample), shutdown (reply, then semihosting exit 0).
//! After enabling its serial port the device sends a hello: an empty ack numbered 0xFFFF.
//! The step reply is [`frame::StepReply`]; the prediction is 0 and `ready` 0 until the
//! predictor's window is full. Requests are numbered 0, 1, 2, ...: a frame with a bad CRC or
//! an unexpected number is answered with an error reply ([`Fault`]) and changes nothing; an
//! unknown kind or a payload length the kind does not take is answered with [`Fault::Kind`]
//! (its number counts), a number of counts other than the controller's coordinates with
//! [`Fault::Counts`].
#![no_std]
#![no_main]

use controller::IntPd;
use controller::predictor::{Predictor, SqrtFlavour};
use cortex_m_rt::{ExceptionFrame, entry, exception};
use cortex_m_semihosting::{debug, hprintln};
use panic_semihosting as _;
use shared::frame::{self, Direction, Fault, FrameError, Kind, LoadReply, Prime, Receiver, Seq, Step, StepReply};

/// Capacities: p <= 16, d <= 6, K <= 256, lift terms <= 84, window <= 64.
type Pred = Predictor<16, 6, 256, 84, 64>;
static mut PREDICTOR: Pred = Pred::empty(SqrtFlavour::Libm);
const BLOB_CAP: usize = 64 * 1024;
static mut BLOB: [u8; BLOB_CAP] = [0; BLOB_CAP];

#[path = "../board.rs"]
mod board;
use board::{read_byte, write_byte};

/// Sequence number of the hello reply (the one before the first request's 0).
const HELLO: Seq = Seq(u16::MAX);

/// Largest reply payload (the step reply has 10 bytes).
const REPLY_CAP: usize = 16;

fn reply(kind: Kind, seq: Seq, payload: &[u8]) {
    let mut buf = [0u8; frame::frame_len(REPLY_CAP)];
    // Every reply payload fits REPLY_CAP; one that did not would go unanswered.
    if let Ok(n) = frame::encode(kind, seq, payload, &mut buf) {
        for &b in &buf[..n] {
            write_byte(b);
        }
    }
}

fn fault(seq: Seq, f: Fault) {
    reply(Kind::Error, seq, &[f.code()]);
}

#[entry]
fn main() -> ! {
    board::serial_init();
    // Hello: the port is ready. Bytes sent before it was enabled may be lost (the STM32's
    // USART drops them), so the host waits for this before its first request.
    reply(Kind::Ack, HELLO, &[]);
    // SAFETY: the only references to these statics, taken once here.
    let pred = unsafe { &mut *(&raw mut PREDICTOR) };
    let blob = unsafe { &mut *(&raw mut BLOB) };
    let mut blob_len = 0usize;
    let mut pd: Option<IntPd<8>> = None;
    let mut expected = Seq(0);
    let mut rx = Receiver::new(Direction::Request);
    loop {
        // The receiver hunts for the start byte, then takes the header, payload and CRC.
        let Some(received) = rx.push(read_byte()) else {
            continue;
        };
        // An unknown kind is refused like a wrong payload length, after the sequence check.
        let (seq, request) = match received {
            Ok(f) => (f.seq, Some((f.kind, f.payload))),
            Err(FrameError::UnknownKind { seq, .. }) => (seq, None),
            Err(FrameError::Crc { seq, .. }) => {
                fault(seq, Fault::Crc);
                continue;
            }
            // The receiver only completes frames with a request start byte, whole: nothing
            // else reaches here.
            Err(_) => continue,
        };
        if seq != expected {
            fault(seq, Fault::Seq);
            continue;
        }
        expected = expected.next();
        let Some((kind, payload)) = request else {
            fault(seq, Fault::Kind);
            continue;
        };
        match (kind, payload.len()) {
            (Kind::ModelChunk, len) => match blob.get_mut(blob_len..blob_len + len) {
                Some(dst) => {
                    dst.copy_from_slice(payload);
                    blob_len += len;
                    reply(Kind::Ack, seq, &[]);
                }
                None => fault(seq, Fault::BlobFull),
            },
            (Kind::Load, 0) => match pred.load(&blob[..blob_len]) {
                Ok(()) => match IntPd::<8>::try_new(pred.model().config()) {
                    Ok(p) => {
                        let r = LoadReply { delay: p.delay().min(255) as u8, coordinates: p.coordinates() as u8 };
                        pd = Some(p);
                        let mut b = [0u8; LoadReply::LEN];
                        let n = r.encode(&mut b).unwrap_or(0);
                        reply(Kind::Ack, seq, &b[..n]);
                    }
                    Err(_) => fault(seq, Fault::Config),
                },
                Err(_) => fault(seq, Fault::Load),
            },
            (Kind::Prime, _) => match (Prime::decode(payload), &mut pd) {
                (Err(_), _) => fault(seq, Fault::Kind),
                (Ok(_), None) => fault(seq, Fault::NotLoaded),
                (Ok(Prime(c)), Some(p)) => match p.prime_constant(c.as_slice()) {
                    Ok(()) => {
                        pred.reset();
                        reply(Kind::Ack, seq, &[]);
                    }
                    Err(_) => fault(seq, Fault::Counts),
                },
            },
            (Kind::Step, _) => match (Step::decode(payload), &mut pd) {
                (Err(_), _) => fault(seq, Fault::Kind),
                (Ok(_), None) => fault(seq, Fault::NotLoaded),
                (Ok(s), Some(p)) => match (s.counts.as_slice().len() == p.coordinates()).then_some(s) {
                    Some(s) => {
                        let out = p.step_counts(s.counts.padded());
                        let (ready, prediction) = match pred.push(s.sample).and_then(|()| pred.predict(1)) {
                            Ok(y) => (true, y),
                            Err(_) => (false, 0.0),
                        };
                        let r = StepReply { code: out.code, saturated: out.saturated, ready, prediction };
                        let mut b = [0u8; StepReply::LEN];
                        let n = r.encode(&mut b).unwrap_or(0);
                        reply(Kind::StepReply, seq, &b[..n]);
                    }
                    None => fault(seq, Fault::Counts),
                },
            },
            (Kind::Shutdown, 0) => {
                reply(Kind::Ack, seq, &[]);
                debug::exit(debug::EXIT_SUCCESS);
            }
            _ => fault(seq, Fault::Kind),
        }
    }
}

#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    hprintln!("pil: hard fault at pc {:#x}", ef.pc());
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
