//! Code fingerprints for the report's cache: a CRC-64 of each workspace crate `ssmctl` uses
//! (its `src/`, manifest and build script; `sim` also of the bundled `scenes/` it compiles in),
//! of each of `ssmctl`'s own source files, and of the toolchain (compiler version, profile,
//! target, `Cargo.lock`). A cached report section is reused only while the fingerprints of the
//! code it runs are unchanged.

use std::path::{Path, PathBuf};

const CRC: crc::Crc<u64> = crc::Crc::<u64>::new(&crc::CRC_64_ECMA_182);

/// The workspace crates `ssmctl` depends on (directly or through another), as (name, folder
/// relative to this crate, extra folders relative to it).
const CRATES: &[(&str, &str, &[&str])] = &[
    ("shared", "../../shared", &[]),
    ("controller", "../../controller", &[]),
    ("infile", "../infile", &[]),
    ("fileio", "../fileio", &[]),
    ("sim", "../sim", &["../../scenes"]),
    ("ssm", "../ssm", &[]),
    ("chaos", "../chaos", &[]),
    ("furuta", "../furuta", &[]),
    ("chaos_study", "../chaos_study", &[]),
];

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else { return };
    let mut entries: Vec<PathBuf> = rd.filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            files(&p, out);
        } else if p.is_file() {
            out.push(p);
        }
    }
}

fn digest_files(paths: &[PathBuf], base: &Path) -> u64 {
    let mut d = CRC.digest();
    for p in paths {
        let rel = p.strip_prefix(base).unwrap_or(p).to_string_lossy().into_owned();
        let bytes = std::fs::read(p).unwrap_or_default();
        d.update(&(rel.len() as u64).to_le_bytes());
        d.update(rel.as_bytes());
        d.update(&(bytes.len() as u64).to_le_bytes());
        d.update(&bytes);
    }
    d.finalize()
}

fn main() {
    let here = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let mut out = String::from(
        "/// (crate, CRC-64 of its sources) for the workspace crates ssmctl uses.\npub const CRATES: &[(&str, u64)] = &[\n",
    );
    for (name, rel, extra) in CRATES {
        let dir = here.join(rel);
        let mut paths = Vec::new();
        files(&dir.join("src"), &mut paths);
        for f in ["Cargo.toml", "build.rs"] {
            if dir.join(f).is_file() {
                paths.push(dir.join(f));
            }
        }
        println!("cargo:rerun-if-changed={}", dir.join("src").display());
        println!("cargo:rerun-if-changed={}", dir.join("Cargo.toml").display());
        for e in *extra {
            let x = here.join(e);
            files(&x, &mut paths);
            println!("cargo:rerun-if-changed={}", x.display());
        }
        out.push_str(&format!("    ({name:?}, 0x{:016x}),\n", digest_files(&paths, &dir)));
    }
    out.push_str("];\n/// (path under ssmctl's src/, CRC-64 of the file).\npub const FILES: &[(&str, u64)] = &[\n");
    let src = here.join("src");
    let mut own = Vec::new();
    files(&src, &mut own);
    println!("cargo:rerun-if-changed={}", src.display());
    for p in &own {
        let rel = p.strip_prefix(&src).unwrap_or(p).to_string_lossy().into_owned();
        out.push_str(&format!("    ({rel:?}, 0x{:016x}),\n", digest_files(std::slice::from_ref(p), &src)));
    }
    out.push_str("];\n");
    let lock = here.join("../../Cargo.lock");
    println!("cargo:rerun-if-changed={}", lock.display());
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let version = std::process::Command::new(&rustc)
        .arg("-vV")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
        .unwrap_or_default();
    let mut d = CRC.digest();
    for part in [
        version.as_bytes(),
        std::env::var("PROFILE").unwrap_or_default().as_bytes(),
        std::env::var("OPT_LEVEL").unwrap_or_default().as_bytes(),
        std::env::var("TARGET").unwrap_or_default().as_bytes(),
        &std::fs::read(&lock).unwrap_or_default(),
        &std::fs::read(here.join("Cargo.toml")).unwrap_or_default(),
    ] {
        d.update(&(part.len() as u64).to_le_bytes());
        d.update(part);
    }
    out.push_str(&format!(
        "/// Compiler version, profile, optimization level, target, Cargo.lock and ssmctl's manifest.\npub const TOOLCHAIN: u64 = 0x{:016x};\n",
        d.finalize()
    ));
    let dest = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("fingerprints.rs");
    std::fs::write(dest, out).expect("writing the fingerprints into OUT_DIR");
}
