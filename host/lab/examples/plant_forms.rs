//! The plant-form table of `ssmctl bench simulate` with exact instruction counts: the
//! built-in Furuta and the same plant written as equations (`furuta-equations`), its tapes
//! run as native code and interpreted, per `f64`
//! right-hand side, per Jacobian as the exprb integrators take it (`Plant::exact_jacobian`:
//! dual numbers for the built-in plant, the compiled symbolic derivatives for the equations)
//! and per sampling period of the bench's integrators, counted by valgrind (cachegrind
//! without cache simulation; the difference of two run lengths, so start-up cancels), next
//! to the bench's CPU-time rows of the same run. `--write` stores the JSON in
//! `docs/plant-forms.json` and the table in `docs/plant-forms.md`.
//!
//! ```text
//! cargo run --release -p lab --example plant_forms -- [--write] [--quick]
//! target/release/examples/plant_forms count FORM WHAT N   # what valgrind runs
//! ```
//! FORM is `built-in`, `equations` or `interpreted`; WHAT is `rhs`, `jacobian`, `dual-jacobian` (the
//! dual-number Jacobian whatever the plant's own; N evaluations) or `exprb`, `rk4` (N
//! sampling periods of the bench problem).

use serde::Serialize;
use sim::closed_loop::{AnyPlant, build_plant, simulate};
use sim::plant::Plant;
use sim::scene::Scene;
use std::fmt::Write as _;
use std::process::Command;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// The state and input of the per-evaluation counts (near the bench run's).
const X: [f64; 4] = [0.05, 0.025, 0.0166, 0.0125];
const U: f64 = 0.3;

fn scene(form: &str, periods: u64) -> Res<Scene> {
    let (b, e) = ssmctl::bench::plant_form_scenes(periods)?;
    match form {
        "built-in" => Ok(b),
        "equations" | "interpreted" => Ok(e),
        _ => Err(format!("unknown plant form `{form}` (built-in, equations, interpreted)").into()),
    }
}

fn evaluate<P: Plant<4>>(p: &P, what: &str, n: u64) -> Res<()> {
    for _ in 0..n {
        match what {
            "rhs" => {
                std::hint::black_box(p.rhs(std::hint::black_box(&X), std::hint::black_box(U)));
            }
            "jacobian" => {
                std::hint::black_box(p.exact_jacobian(std::hint::black_box(&X), std::hint::black_box(U)));
            }
            "dual-jacobian" => {
                std::hint::black_box(sim::plant::linearize::dual_jacobian(
                    p,
                    std::hint::black_box(&X),
                    std::hint::black_box(U),
                ));
            }
            _ => return Err(format!("unknown count `{what}`").into()),
        }
    }
    Ok(())
}

/// The child: `n` evaluations or `n` periods, nothing printed; the `interpreted` form's
/// tapes compiled without native code.
fn count(form: &str, what: &str, n: u64) -> Res<()> {
    if form == "interpreted" {
        return sim::expr::interpreted(|| count_form("equations", what, n));
    }
    count_form(form, what, n)
}

fn count_form(form: &str, what: &str, n: u64) -> Res<()> {
    if let Some(&(method, rtol, steps)) = ssmctl::bench::PLANT_FORM_INTEGRATORS.iter().find(|(m, _, _)| {
        matches!((what, m), ("exprb", sim::scene::MethodKind::Exprb) | ("rk4", sim::scene::MethodKind::Rk4))
    }) {
        let (s, _) = ssmctl::bench::with_integrator(&scene(form, n)?, method, rtol, steps);
        std::hint::black_box(simulate(&s, None)?);
        return Ok(());
    }
    match build_plant(&scene(form, 1)?)? {
        AnyPlant::Furuta(p) => evaluate(&p, what, n),
        AnyPlant::Equations2(p) => evaluate(&p, what, n),
        _ => Err("the bench scenes have four states".into()),
    }
}

/// Instructions of `self count form what n` under cachegrind.
fn instructions(form: &str, what: &str, n: u64) -> Res<u64> {
    let exe = std::env::current_exe()?;
    let out = Command::new("valgrind")
        .args(["--tool=cachegrind", "--cache-sim=no", "--cachegrind-out-file=/dev/null"])
        .arg(&exe)
        .args(["count", form, what, &n.to_string()])
        .output()?;
    let text = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        return Err(format!("valgrind {form} {what} {n} failed: {text}").into());
    }
    let line = text.lines().find(|l| l.contains("I   refs:") || l.contains("I refs:")).ok_or("no `I refs` line")?;
    let digits: String = line.rsplit(':').next().unwrap_or("").chars().filter(char::is_ascii_digit).collect();
    Ok(digits.parse()?)
}

/// Instructions per unit: the difference of two run lengths over their difference.
fn per_unit(form: &str, what: &str, n1: u64, n2: u64) -> Res<f64> {
    let (a, b) = (instructions(form, what, n1)?, instructions(form, what, n2)?);
    Ok((b as f64 - a as f64) / (n2 - n1) as f64)
}

#[derive(Serialize)]
struct FormCounts {
    plant: String,
    /// Instructions per `f64` right-hand side.
    rhs: f64,
    /// Instructions per Jacobian (`Plant::exact_jacobian`).
    jacobian: f64,
    /// Instructions per sampling period, by integrator label.
    per_period: Vec<(String, f64)>,
    /// Tape instructions (value tape; Jacobian tape), equations only.
    tape_instructions: Option<usize>,
    jacobian_tape_instructions: Option<usize>,
}

#[derive(Serialize)]
struct Report {
    produced_by: String,
    valgrind: String,
    counts: Vec<FormCounts>,
    bench: ssmctl::bench::PlantForms,
}

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("count") {
        let n: u64 = args.get(3).ok_or("count FORM WHAT N")?.parse()?;
        return count(args.get(1).ok_or("FORM")?, args.get(2).ok_or("WHAT")?, n);
    }
    let write = args.iter().any(|a| a == "--write");
    let quick = args.iter().any(|a| a == "--quick");
    let version = Command::new("valgrind").arg("--version").output();
    let valgrind = match &version {
        Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stdout).trim().to_string(),
        _ => return Err("valgrind is not installed: the instruction counts need it".into()),
    };
    let (e1, e2) = if quick { (200, 1200) } else { (1000, 11_000) };
    let (p1, p2) = (1u64, if quick { 51 } else { 201 });
    let mut counts = Vec::new();
    for form in ssmctl::bench::PLANT_FORMS {
        eprintln!("counting {form}");
        let mut per_period = Vec::new();
        for (m, r, s) in ssmctl::bench::PLANT_FORM_INTEGRATORS {
            let what = if matches!(m, sim::scene::MethodKind::Rk4) { "rk4" } else { "exprb" };
            let (_, label) = ssmctl::bench::with_integrator(&scene(form, 1)?, m, r, s);
            per_period.push((label, per_unit(form, what, p1, p2)?));
        }
        let build = || build_plant(&scene(form, 1)?).map_err(Into::into);
        let plant: Res<AnyPlant> = if form == "interpreted" { sim::expr::interpreted(build) } else { build() };
        let (tape, jac_tape) = match plant? {
            AnyPlant::Equations2(p) => (Some(p.model().tape().len()), p.model().jac_tape().map(|t| t.len())),
            _ => (None, None),
        };
        counts.push(FormCounts {
            plant: form.to_string(),
            rhs: per_unit(form, "rhs", e1, e2)?,
            jacobian: per_unit(form, "jacobian", e1, e2)?,
            per_period,
            tape_instructions: tape,
            jacobian_tape_instructions: jac_tape,
        });
    }
    eprintln!("timing (ssmctl bench simulate's plant forms)");
    let bench = ssmctl::bench::bench_plant_forms(200, quick, |_| {})?;
    let report = Report {
        produced_by: format!(
            "cargo run --release -p lab --example plant_forms -- --write{}",
            if quick { " --quick" } else { "" }
        ),
        valgrind,
        counts,
        bench,
    };
    let md = markdown(&report)?;
    let json = serde_json::to_string_pretty(&report)?;
    if write {
        let docs = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs");
        fileio::write_atomic(&docs.join("plant-forms.json"), json.as_bytes())?;
        fileio::write_atomic(&docs.join("plant-forms.md"), md.as_bytes())?;
        eprintln!("wrote docs/plant-forms.json and docs/plant-forms.md");
    } else {
        println!("{md}");
    }
    Ok(())
}

fn markdown(r: &Report) -> Res<String> {
    let mut md = String::new();
    writeln!(md, "# Plant forms: the built-in Furuta against `furuta-equations` (generated)\n")?;
    writeln!(
        md,
        "Written by `{}` ({}); do not edit. The bench problem of `ssmctl bench simulate` \
         (furuta-dt30.8, 200 periods from theta0 = 0.05 rad) with the plant built in and \
         written as equations, the latter's tapes run as native code (`equations`) and \
         interpreted (`interpreted`). Instructions are exact counts (valgrind, release build; the \
         difference of two run lengths). CPU time: {} rounds, each one run of every form \
         back to back (thread CPU time), on a machine shared with other jobs (load average \
         {} before, {} after); the CPU ratio is the median of the rounds' ratios (their range \
         in brackets), the CPU time per period the median of the rounds.\n",
        r.produced_by,
        r.valgrind,
        r.bench.rows.first().map_or(0, |row| row.rounds),
        r.bench.load_average[0].map_or("-".into(), |l| format!("{l:.2}")),
        r.bench.load_average[1].map_or("-".into(), |l| format!("{l:.2}")),
    )?;
    writeln!(md, "| plant | instructions / rhs | instructions / Jacobian | tape (value; Jacobian) |")?;
    writeln!(md, "|---|---|---|---|")?;
    let base = r.counts.first();
    for c in &r.counts {
        let ratio = |v: f64, b: f64| if c.plant == "built-in" { String::new() } else { format!(" ({:.2}x)", v / b) };
        let tapes = match (c.tape_instructions, c.jacobian_tape_instructions) {
            (Some(t), Some(j)) => format!("{t}; {j}"),
            _ => "-".into(),
        };
        writeln!(
            md,
            "| {} | {:.0}{} | {:.0}{} | {tapes} |",
            c.plant,
            c.rhs,
            ratio(c.rhs, base.map_or(1.0, |b| b.rhs)),
            c.jacobian,
            ratio(c.jacobian, base.map_or(1.0, |b| b.jacobian)),
        )?;
    }
    writeln!(
        md,
        "\n| plant | integrator | instructions / period | x built-in | CPU us / period | x built-in | max err rad |"
    )?;
    writeln!(md, "|---|---|---|---|---|---|---|")?;
    for row in &r.bench.rows {
        let find = |plant: &str| {
            r.counts
                .iter()
                .find(|c| c.plant == plant)
                .and_then(|c| c.per_period.iter().find(|(l, _)| *l == row.integrator).map(|(_, v)| *v))
        };
        let (mine, builtin) = (find(&row.plant), find("built-in"));
        let ins = mine.map_or("-".into(), |v| format!("{v:.0}"));
        let ins_ratio = match (mine, builtin) {
            (Some(a), Some(b)) => format!("{:.2}", a / b),
            _ => "-".into(),
        };
        writeln!(
            md,
            "| {} | {} | {ins} | {ins_ratio} | {:.2} | {:.2}{} | {:.2e} |",
            row.plant,
            row.integrator,
            1e6 * row.cpu_s_per_period,
            row.cpu_ratio_vs_builtin,
            if row.plant == "built-in" {
                String::new()
            } else {
                format!(" [{:.2}, {:.2}]", row.cpu_ratio_range[0], row.cpu_ratio_range[1])
            },
            row.max_err_rad
        )?;
    }
    Ok(md)
}
