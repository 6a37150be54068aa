//! Randomized robustness: >= 1,000,000 mutated blobs (bit flips, byte changes, truncations,
//! extensions, and combinations) are decoded; none may panic and none that differs from the
//! original may be accepted. Deterministic (fixed seed), so a failure reproduces.

use crate::common;

use std::time::Instant;

use shared::model::{DecodeError, Model};

const CASES: u64 = 1_000_000;

/// SplitMix64: a small, well-mixed deterministic generator (no dependency needed).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

fn mutate(rng: &mut Rng, blob: &mut Vec<u8>) {
    let edits = 1 + rng.below(3);
    for _ in 0..edits {
        match rng.below(8) {
            // Single bit flip anywhere (most common: what a flash or link error looks like).
            0..=2 if !blob.is_empty() => {
                let i = rng.below(blob.len());
                blob[i] ^= 1 << rng.below(8);
            }
            // Bit flip in the header, where every field is checked differently.
            3 if blob.len() >= 22 => {
                let i = rng.below(22);
                blob[i] ^= 1 << rng.below(8);
            }
            // Replace a byte with a random value.
            4 if !blob.is_empty() => {
                let i = rng.below(blob.len());
                blob[i] = rng.next() as u8;
            }
            // Truncate to a random length.
            5 => {
                let n = rng.below(blob.len() + 1);
                blob.truncate(n);
            }
            // Extend by random bytes.
            6 => {
                for _ in 0..1 + rng.below(16) {
                    blob.push(rng.next() as u8);
                }
            }
            // Overwrite a random run of bytes.
            _ if !blob.is_empty() => {
                let start = rng.below(blob.len());
                let len = 1 + rng.below(8);
                for b in blob.iter_mut().skip(start).take(len) {
                    *b = rng.next() as u8;
                }
            }
            _ => blob.push(0),
        }
    }
}

#[derive(Default, Debug)]
struct Tally {
    no_op: u64,
    accepted_altered: u64,
    bad_magic: u64,
    version: u64,
    truncated: u64,
    trailing: u64,
    crc: u64,
    other: u64,
}

#[test]
fn million_mutated_blobs_are_rejected_without_panic() {
    let originals = [common::encode(&common::tiny()), common::encode(&common::pinned())];
    let mut model = Model::<8, 4, 8, 16>::empty();
    for o in &originals {
        model.decode_into(o).expect("original decodes");
    }
    let mut rng = Rng(0x5353_4d52_0000_0001);
    let mut t = Tally::default();
    let start = Instant::now();
    let mut blob = Vec::with_capacity(512);
    for case in 0..CASES {
        let original = &originals[(case & 1) as usize];
        blob.clear();
        blob.extend_from_slice(original);
        mutate(&mut rng, &mut blob);
        let result = model.decode_into(&blob);
        if blob == *original {
            t.no_op += 1;
            assert_eq!(result, Ok(()), "an unaltered blob must decode");
            continue;
        }
        match result {
            Ok(()) => {
                t.accepted_altered += 1;
                eprintln!("accepted altered blob (case {case}): {blob:02x?}");
            }
            Err(DecodeError::BadMagic { .. }) => t.bad_magic += 1,
            Err(DecodeError::UnsupportedVersion { .. }) => t.version += 1,
            Err(DecodeError::Truncated { .. }) => t.truncated += 1,
            Err(DecodeError::TrailingBytes { .. }) => t.trailing += 1,
            Err(DecodeError::Crc { .. }) => t.crc += 1,
            Err(_) => t.other += 1,
        }
    }
    let elapsed = start.elapsed();
    println!("{CASES} mutated blobs in {elapsed:.2?}: {t:?}");
    assert_eq!(t.accepted_altered, 0, "altered blobs accepted: {t:?}");
    // The mutations reach every header check, not just one.
    for (name, n) in [
        ("bad magic", t.bad_magic),
        ("version", t.version),
        ("truncated", t.truncated),
        ("trailing", t.trailing),
        ("crc", t.crc),
    ] {
        assert!(n > 1000, "too few {name} rejections: {t:?}");
    }
}
