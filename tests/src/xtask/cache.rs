//! Content-addressed reuse of expensive runs (the processor-in-the-loop recordings): a run's
//! output folder holds `cache-key`, a CRC-64 fingerprint of everything the run's result
//! depends on (firmware image, host binary, scene and overrides, model, periods). A later
//! run with the same fingerprint and a complete output is skipped and says so; `--fresh`
//! forces it. Not a security boundary: CRC-64 detects changed inputs, it does not resist
//! crafted collisions.

use std::path::Path;

const FINGERPRINT: crc::Crc<u64> = crc::Crc::<u64>::new(&crc::CRC_64_ECMA_182);

/// Fingerprint of `parts` (each length-prefixed, so the split between parts counts).
pub fn key(parts: &[&[u8]]) -> String {
    let mut d = FINGERPRINT.digest();
    for p in parts {
        d.update(&(p.len() as u64).to_le_bytes());
        d.update(p);
    }
    format!("{:016x}", d.finalize())
}

/// Whether `dir` holds a completed run with fingerprint `key`.
pub fn hit(dir: &Path, key: &str) -> bool {
    std::fs::read_to_string(dir.join("cache-key")).is_ok_and(|k| k.trim() == key)
}

/// Marks `dir` as the completed run with fingerprint `key` (after its checks passed).
pub fn store(dir: &Path, key: &str) -> Result<(), String> {
    let path = dir.join("cache-key");
    crate::files::write_atomic(&path, format!("{key}\n").as_bytes())
}

/// Forgets a run (before it is redone), so a failed redo is never taken for a hit.
pub fn forget(dir: &Path) {
    let _ = std::fs::remove_file(dir.join("cache-key"));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fingerprint_depends_on_every_part_and_the_split() {
        let a = key(&[b"elf", b"scene", b"20000"]);
        assert_eq!(a, key(&[b"elf", b"scene", b"20000"]));
        assert_ne!(a, key(&[b"elf", b"scene", b"20001"]));
        assert_ne!(key(&[b"ab", b"c"]), key(&[b"a", b"bc"]));
        assert_eq!(a.len(), 16);
    }

    #[test]
    fn hit_store_forget() {
        let dir = std::env::temp_dir().join(format!("xtask-cache-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        assert!(!hit(&dir, "00"));
        store(&dir, "00").unwrap();
        assert!(hit(&dir, "00") && !hit(&dir, "01"));
        forget(&dir);
        assert!(!hit(&dir, "00"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
