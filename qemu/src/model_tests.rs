//! Model blob decoding and the RBF predictor, against expected outputs computed on the host
//! by the same `controller::predictor` code (compared as exact `f32` bits).

use controller::predictor::{LoadError, Predictor, SqrtFlavour};
use cortex_m_semihosting::hprintln;
use shared::model::{DecodeError, HEADER_LEN, Model};

use crate::data;

/// Capacities of this firmware build (the generated model must fit them).
type Pred = Predictor<16, 6, 64, 64, 64>;
type Mdl = Model<16, 6, 64, 64>;
/// Largest blob the corruption tests copy into RAM.
const BLOB_CAP: usize = 8192;

// Single-threaded, no interrupt touches them: each test takes them once via the accessors.
static mut PREDICTOR: Pred = Pred::empty(SqrtFlavour::DEFAULT);
static mut MODEL: Mdl = Mdl::empty();
static mut SCRATCH: [u8; BLOB_CAP] = [0; BLOB_CAP];

fn predictor() -> &'static mut Pred {
    // SAFETY: tests run one at a time from `main` and drop the reference before returning.
    unsafe { &mut *(&raw mut PREDICTOR) }
}
fn model() -> &'static mut Mdl {
    // SAFETY: as above.
    unsafe { &mut *(&raw mut MODEL) }
}
fn scratch() -> Result<&'static mut [u8], &'static str> {
    // SAFETY: as above.
    let buf = unsafe { &mut *(&raw mut SCRATCH) };
    buf.get_mut(..data::MODEL_BLOB.len()).ok_or("model blob larger than the scratch buffer")
}

pub fn decodes_embedded_blob() -> Result<(), &'static str> {
    let m = model();
    if let Err(e) = m.decode_into(data::MODEL_BLOB) {
        hprintln!("decode error: {}", e);
        return Err("embedded blob rejected");
    }
    let got = [m.p(), m.d(), m.k(), m.lift_terms(), m.shift()];
    if got != data::DIMS {
        hprintln!("dims {:?}, expected {:?}", got, data::DIMS);
        return Err("decoded dimensions differ from the host's");
    }
    if m.scale().to_bits() != data::SCALE_BITS || m.offset().to_bits() != data::OFFSET_BITS {
        return Err("decoded normalization differs from the host's");
    }
    Ok(())
}

/// One corruption per header check, each must give its own error variant.
pub fn rejects_targeted_corruptions() -> Result<(), &'static str> {
    let n = data::MODEL_BLOB.len();
    let m = model();
    let cases: [(&str, fn(&mut [u8]) -> usize, fn(&DecodeError) -> bool); 6] = [
        (
            "magic",
            |b| {
                b[0] ^= 0x20;
                b.len()
            },
            |e| matches!(e, DecodeError::BadMagic { .. }),
        ),
        (
            "version",
            |b| {
                b[4] = 0x7f;
                b.len()
            },
            |e| matches!(e, DecodeError::UnsupportedVersion { found: 0x7f, .. }),
        ),
        ("truncated", |b| b.len() - 1, |e| matches!(e, DecodeError::Truncated { .. })),
        (
            "payload bit",
            |b| {
                b[HEADER_LEN + 3] ^= 0x01;
                b.len()
            },
            |e| matches!(e, DecodeError::Crc { .. }),
        ),
        (
            "crc bit",
            |b| {
                b[18] ^= 0x80;
                b.len()
            },
            |e| matches!(e, DecodeError::Crc { .. }),
        ),
        (
            "header d",
            |b| {
                b[6] ^= 0x01;
                b.len()
            },
            |e| matches!(e, DecodeError::ShapeMismatch { what: "d", .. }),
        ),
    ];
    for (name, corrupt, expected) in cases {
        let buf = scratch()?;
        buf.copy_from_slice(data::MODEL_BLOB);
        let len = corrupt(buf);
        match m.decode_into(buf.get(..len).ok_or("bad length")?) {
            Err(e) if expected(&e) => {}
            other => {
                hprintln!("corruption '{}' (blob {} bytes): got {:?}", name, n, other);
                return Err("wrong verdict for a targeted corruption");
            }
        }
    }
    Ok(())
}

/// xorshift32: deterministic mutations.
struct Rng(u32);
impl Rng {
    fn next(&mut self) -> u32 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.0 = x;
        x
    }
    fn below(&mut self, n: usize) -> usize {
        if n == 0 { 0 } else { self.next() as usize % n }
    }
}

/// Random bit flips, byte changes and truncations: every altered blob must be rejected.
pub fn rejects_random_corruptions() -> Result<(), &'static str> {
    let n = data::MODEL_BLOB.len();
    let m = model();
    let mut rng = Rng(0x5353_4d52);
    let mut rejected = 0u32;
    for case in 0..data::CORRUPT_CASES {
        let buf = scratch()?;
        buf.copy_from_slice(data::MODEL_BLOB);
        let mut len = n;
        for _ in 0..1 + rng.below(3) {
            match rng.below(3) {
                0 => {
                    let i = rng.below(len);
                    if let Some(b) = buf.get_mut(i) {
                        *b ^= 1 << rng.below(8);
                    }
                }
                1 => {
                    let i = rng.below(len);
                    if let Some(b) = buf.get_mut(i) {
                        *b = rng.next() as u8;
                    }
                }
                _ => len = rng.below(len),
            }
        }
        let blob = buf.get(..len).ok_or("bad length")?;
        if blob == data::MODEL_BLOB {
            continue; // a no-op mutation (e.g. a byte set to its own value)
        }
        if m.decode_into(blob).is_ok() {
            hprintln!("case {}: altered blob of {} bytes accepted", case, len);
            return Err("an altered blob was accepted");
        }
        rejected += 1;
    }
    hprintln!("  {} corrupted blobs rejected", rejected);
    if rejected < data::CORRUPT_CASES / 2 {
        return Err("too many no-op mutations: the test lost its power");
    }
    Ok(())
}

fn load(sqrt: SqrtFlavour) -> Result<&'static mut Pred, &'static str> {
    let p = predictor();
    p.set_sqrt_flavour(sqrt);
    match p.load(data::MODEL_BLOB) {
        Ok(()) => Ok(p),
        Err(LoadError::Decode(e)) => {
            hprintln!("load: {}", e);
            Err("model did not load")
        }
        Err(e) => {
            hprintln!("load: {}", e);
            Err("model did not fit")
        }
    }
}

fn compare(what: &str, i: usize, got: f32, want_bits: u32) -> Result<(), &'static str> {
    if got.to_bits() != want_bits {
        hprintln!(
            "{} #{}: got {:e} ({:#010x}), host {:e} ({:#010x})",
            what,
            i,
            got,
            got.to_bits(),
            f32::from_bits(want_bits),
            want_bits
        );
        return Err("output differs from the host's bits");
    }
    Ok(())
}

/// Push the inputs one by one; once the window is full, predict `HORIZON` steps ahead
/// after every push.
fn rolling(flavour: usize) -> Result<(), &'static str> {
    let p = load(SqrtFlavour::ALL.get(flavour).copied().ok_or("flavour index")?)?;
    let expected = data::ROLLING.get(flavour).ok_or("flavour index")?;
    let mut k = 0usize;
    for &bits in data::INPUTS.iter() {
        p.push(f32::from_bits(bits)).map_err(|_| "input refused")?;
        if p.is_ready() {
            let got = p.predict(data::HORIZON).map_err(|_| "predict failed")?;
            compare("rolling prediction", k, got, *expected.get(k).ok_or("more predictions than expected")?)?;
            k += 1;
        }
    }
    if k != expected.len() {
        return Err("fewer predictions than expected");
    }
    Ok(())
}

pub fn rolling_libm() -> Result<(), &'static str> {
    rolling(0)
}
pub fn rolling_fast() -> Result<(), &'static str> {
    rolling(1)
}
pub fn rolling_hardware() -> Result<(), &'static str> {
    rolling(2)
}

/// From the final window, iterate the map and lift after every step, per flavour.
pub fn free_run_all() -> Result<(), &'static str> {
    for (flavour, sqrt) in SqrtFlavour::ALL.into_iter().enumerate() {
        let p = load(sqrt)?;
        for &bits in data::INPUTS.iter() {
            p.push(f32::from_bits(bits)).map_err(|_| "input refused")?;
        }
        let mut eta = p.reduce().map_err(|_| "window not full")?;
        let expected = data::FREE_RUN.get(flavour).ok_or("flavour index")?;
        for (i, &want) in expected.iter().enumerate() {
            eta = p.step(&eta);
            compare("free-run lift", i, p.lift(&eta), want)?;
        }
    }
    Ok(())
}
