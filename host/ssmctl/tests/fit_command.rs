use ssm::Dynamics;
use ssmctl::fit_command::*;

/// `--dynamics rbf:KERNEL` picks the kernel; `rbf` is the linear default; bad kernels
/// are errors naming the option.
#[test]
fn dynamics_with_kernels_parse() {
    assert_eq!(parse_dynamics("rbf", 7), Ok(Dynamics::Rbf { centers: 7 }));
    assert_eq!(parse_dynamics("rbf:cubic", 7), Ok(Dynamics::RbfWith { centers: 7, kernel: ssm::Kernel::Cubic }));
    assert_eq!(
        parse_dynamics("rbf:gaussian:2", 7),
        Ok(Dynamics::RbfWith { centers: 7, kernel: ssm::Kernel::Gaussian { eps: 2.0 } })
    );
    for bad in ["rbf:quartic", "rbf:gaussian:-1", "spline"] {
        let e = parse_dynamics(bad, 7).unwrap_err();
        assert!(e.contains(&format!("--dynamics `{bad}`")), "{e}");
    }
}

/// The host decoder needs no stack of the caller's (it runs on its own thread): `inspect`
/// of the reference blob works from a thread with a 256 KiB stack, where the several-MB
/// model built on the caller's stack overflowed (exit 134 of `export`/`inspect` in the
/// dev profile).
#[test]
fn inspect_runs_on_a_small_stack() {
    let blob = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/tests/data/model_v2.bin")).unwrap();
    let v = std::thread::Builder::new()
        .stack_size(256 << 10)
        .spawn(move || inspect(&blob).map_err(|e| e.to_string()))
        .unwrap()
        .join()
        .unwrap()
        .unwrap();
    assert_eq!(v["format_version"], 2);
    assert!(v["p"].as_u64().unwrap() >= 1, "{v}");
}
