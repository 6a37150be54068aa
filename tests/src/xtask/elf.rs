//! Flash and RAM use of a firmware image, read from its ELF32 section headers.

/// Section sizes of an image, in bytes.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Sizes {
    /// Everything stored in flash: code, read-only data, vector table, `.data` initializers.
    pub flash: u64,
    /// Statically allocated RAM: `.data` + `.bss` + `.uninit` (not the stack).
    pub ram: u64,
}

fn u16le(b: &[u8], at: usize) -> Option<u64> {
    Some(u16::from_le_bytes(b.get(at..at + 2)?.try_into().ok()?) as u64)
}
fn u32le(b: &[u8], at: usize) -> Option<u64> {
    Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?) as u64)
}

/// Sizes of an ELF32 little-endian image: flash = allocated PROGBITS sections (their load
/// image), RAM = allocated sections placed at or above `ram_origin`, except `.stack`.
pub fn sizes(elf: &[u8], ram_origin: u64) -> Result<Sizes, String> {
    if elf.get(..4) != Some(b"\x7fELF") || elf.get(4) != Some(&1) || elf.get(5) != Some(&1) {
        return Err("not a little-endian ELF32 file".into());
    }
    let bad = || "truncated ELF header".to_string();
    let shoff = u32le(elf, 0x20).ok_or_else(bad)? as usize;
    let shentsize = u16le(elf, 0x2e).ok_or_else(bad)? as usize;
    let shnum = u16le(elf, 0x30).ok_or_else(bad)? as usize;
    let shstrndx = u16le(elf, 0x32).ok_or_else(bad)? as usize;
    let sh = |i: usize, field: usize| u32le(elf, shoff + i * shentsize + field).ok_or_else(bad);
    let strtab = sh(shstrndx, 0x10)? as usize;
    let name = |off: u64| -> String {
        let start = strtab + off as usize;
        let bytes = elf.get(start..).unwrap_or(&[]);
        let end = bytes.iter().position(|&c| c == 0).unwrap_or(0);
        String::from_utf8_lossy(&bytes[..end]).into_owned()
    };
    let mut s = Sizes::default();
    for i in 0..shnum {
        let (sname, stype, flags, addr, size) = (sh(i, 0)?, sh(i, 4)?, sh(i, 8)?, sh(i, 0x0c)?, sh(i, 0x14)?);
        const SHF_ALLOC: u64 = 2;
        const PROGBITS: u64 = 1;
        if flags & SHF_ALLOC == 0 || size == 0 {
            continue;
        }
        if stype == PROGBITS {
            s.flash += size;
        }
        if addr >= ram_origin && name(sname) != ".stack" {
            s.ram += size;
        }
    }
    Ok(s)
}
