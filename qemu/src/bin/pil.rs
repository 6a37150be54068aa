//! Processor-in-the-loop: the integer PD controller and the RBF predictor answer requests
//! from the host over UART0 (run by `ssmctl pil` / `cargo xtask pil`).
//!
//! Frames (little-endian), CRC-32 (IEEE, reflected, as zlib) over header + payload:
//! request `[0xA5, kind, seq u16, len u8, payload, crc u32]`,
//! reply   `[0x5A, kind, seq u16, len u8, payload, crc u32]`.
//! Request kinds: 1 model chunk (appended to the blob buffer), 2 load (decode the blob:
//! predictor + controller config; reply payload = delay u8), 3 prime (`q_y i32, q_z i32`),
//! 4 step (`q_y i32, q_z i32, sample f32`), 5 shutdown (reply, then semihosting exit 0).
//! Replies: 0x81 ack, 0x84 step (`code i32, saturated u8, ready u8, prediction f32`; the
//! prediction is 0 and `ready` 0 until the predictor's window is full), 0xEE error
//! (`code u8`, see [`Fault`]). Requests are numbered 0, 1, 2, ...: a frame with a bad CRC
//! or an unexpected number is answered with an error and changes nothing.
#![no_std]
#![no_main]

use controller::IntPd;
use controller::predictor::{Predictor, SqrtFlavour};
use cortex_m_rt::{ExceptionFrame, entry, exception};
use cortex_m_semihosting::{debug, hprintln};
use panic_semihosting as _;

/// Capacities: p <= 16, d <= 6, K <= 256, lift terms <= 84, window <= 64.
type Pred = Predictor<16, 6, 256, 84, 64>;
static mut PREDICTOR: Pred = Pred::empty(SqrtFlavour::Libm);
const BLOB_CAP: usize = 64 * 1024;
static mut BLOB: [u8; BLOB_CAP] = [0; BLOB_CAP];

const UART0: usize = 0x4000_4000;
const DATA: *mut u32 = UART0 as *mut u32;
const STATE: *mut u32 = (UART0 + 0x04) as *mut u32;
const CTRL: *mut u32 = (UART0 + 0x08) as *mut u32;
const BAUDDIV: *mut u32 = (UART0 + 0x10) as *mut u32;

fn uart_init() {
    // SAFETY: CMSDK APB UART0 registers of the mps2-an386 board, word-aligned MMIO.
    unsafe {
        BAUDDIV.write_volatile(16);
        CTRL.write_volatile(0b11);
    }
}

fn read_byte() -> u8 {
    // SAFETY: as in `uart_init`.
    unsafe {
        while STATE.read_volatile() & 0b10 == 0 {}
        (DATA.read_volatile() & 0xFF) as u8
    }
}

fn write_byte(b: u8) {
    // SAFETY: as in `uart_init`.
    unsafe {
        while STATE.read_volatile() & 0b01 != 0 {}
        DATA.write_volatile(u32::from(b));
    }
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 { (c >> 1) ^ 0xEDB8_8320 } else { c >> 1 };
        }
    }
    !c
}

/// Error codes sent in 0xEE replies.
#[derive(Clone, Copy)]
enum Fault {
    Crc = 1,
    Seq = 2,
    Kind = 3,
    Load = 4,
    NotLoaded = 5,
    BlobFull = 6,
    Config = 7,
}

fn reply(kind: u8, seq: u16, payload: &[u8]) {
    let mut buf = [0u8; 5 + 16 + 4];
    let n = payload.len().min(16);
    buf[0] = 0x5A;
    buf[1] = kind;
    buf[2..4].copy_from_slice(&seq.to_le_bytes());
    buf[4] = n as u8;
    for (d, s) in buf[5..5 + n].iter_mut().zip(payload) {
        *d = *s;
    }
    let crc = crc32(&buf[..5 + n]);
    buf[5 + n..9 + n].copy_from_slice(&crc.to_le_bytes());
    for &b in &buf[..9 + n] {
        write_byte(b);
    }
}

fn word(p: &[u8], at: usize) -> [u8; 4] {
    let mut w = [0u8; 4];
    if let Some(s) = p.get(at..at + 4) {
        w.copy_from_slice(s);
    }
    w
}

#[entry]
fn main() -> ! {
    uart_init();
    // SAFETY: the only references to these statics, taken once here.
    let pred = unsafe { &mut *(&raw mut PREDICTOR) };
    let blob = unsafe { &mut *(&raw mut BLOB) };
    let mut blob_len = 0usize;
    let mut pd: Option<IntPd<8>> = None;
    let mut expected: u16 = 0;
    let mut frame = [0u8; 5 + 255 + 4];
    loop {
        // Hunt for the start byte, then read the header, payload and CRC.
        while read_byte() != 0xA5 {}
        frame[0] = 0xA5;
        for b in &mut frame[1..5] {
            *b = read_byte();
        }
        let kind = frame[1];
        let seq = u16::from_le_bytes([frame[2], frame[3]]);
        let len = usize::from(frame[4]);
        for b in &mut frame[5..5 + len + 4] {
            *b = read_byte();
        }
        let crc = u32::from_le_bytes(word(&frame, 5 + len));
        if crc != crc32(&frame[..5 + len]) {
            reply(0xEE, seq, &[Fault::Crc as u8]);
            continue;
        }
        if seq != expected {
            reply(0xEE, seq, &[Fault::Seq as u8]);
            continue;
        }
        expected = expected.wrapping_add(1);
        let payload = &frame[5..5 + len];
        match (kind, len) {
            (1, _) => match blob.get_mut(blob_len..blob_len + len) {
                Some(dst) => {
                    dst.copy_from_slice(payload);
                    blob_len += len;
                    reply(0x81, seq, &[]);
                }
                None => reply(0xEE, seq, &[Fault::BlobFull as u8]),
            },
            (2, 0) => match pred.load(&blob[..blob_len]) {
                Ok(()) => match IntPd::<8>::try_new(pred.model().config()) {
                    Ok(p) => {
                        let delay = p.delay().min(255) as u8;
                        pd = Some(p);
                        reply(0x81, seq, &[delay]);
                    }
                    Err(_) => reply(0xEE, seq, &[Fault::Config as u8]),
                },
                Err(_) => reply(0xEE, seq, &[Fault::Load as u8]),
            },
            (3, 8) => match &mut pd {
                Some(p) => {
                    p.prime_constant(i32::from_le_bytes(word(payload, 0)), i32::from_le_bytes(word(payload, 4)));
                    pred.reset();
                    reply(0x81, seq, &[]);
                }
                None => reply(0xEE, seq, &[Fault::NotLoaded as u8]),
            },
            (4, 12) => match &mut pd {
                Some(p) => {
                    let out = p.step(i32::from_le_bytes(word(payload, 0)), i32::from_le_bytes(word(payload, 4)));
                    let sample = f32::from_le_bytes(word(payload, 8));
                    let (ready, y) = match pred.push(sample).and_then(|()| pred.predict(1)) {
                        Ok(y) => (1u8, y),
                        Err(_) => (0u8, 0.0),
                    };
                    let mut r = [0u8; 10];
                    r[0..4].copy_from_slice(&out.code.to_le_bytes());
                    r[4] = u8::from(out.saturated);
                    r[5] = ready;
                    r[6..10].copy_from_slice(&y.to_le_bytes());
                    reply(0x84, seq, &r);
                }
                None => reply(0xEE, seq, &[Fault::NotLoaded as u8]),
            },
            (5, 0) => {
                reply(0x81, seq, &[]);
                debug::exit(debug::EXIT_SUCCESS);
            }
            _ => reply(0xEE, seq, &[Fault::Kind as u8]),
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
