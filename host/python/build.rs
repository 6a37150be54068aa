//! Records how the module is compiled (cargo's `OPT_LEVEL`, `DEBUG` and `PROFILE` given to
//! this build script) for `ssm_ctl.__build__`: timings of an unoptimized module say little
//! about the library, so benches print it.

fn main() {
    for key in ["OPT_LEVEL", "DEBUG", "PROFILE"] {
        println!("cargo:rustc-env=SSM_CTL_BUILD_{key}={}", std::env::var(key).unwrap_or_default());
    }
    println!("cargo:rerun-if-changed=build.rs");
}
