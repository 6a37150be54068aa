//! The tests of `furuta::sweep`.

use furuta::Error;
use furuta::full_system::{ESCAPE_THETA, outcome_of};
use furuta::sweep::shard::{ShardFile, merge};
use furuta::sweep::*;
use sim::closed_loop::simulate;
use sim::scene::Scene;
use sim::scene::SceneBuilder;
use std::path::Path;

fn parse(text: &str) -> Result<Sweep, Error> {
    Sweep::parse("t.toml", text, Path::new("."))
}

const BASIN: &str = r#"
name = "b"
kind = "basin"
scene = "furuta-dt30.5"
[[axes]]
name = "dt_ms"
values = [30.5, 31.8]
[[axes]]
name = "theta0"
lo = 0.02
hi = 0.3
n = 3
[basin]
periods = 300
"#;

const CHART: &str = r#"
name = "c"
kind = "chart"
scene = "furuta-dt25"
[[axes]]
name = "dt_ms"
values = [25.0, 30.8]
[[axes]]
name = "kd"
lo = 0.0
hi = 8.0
n = 4
[[axes]]
name = "kp"
lo = 0.0
hi = 40.0
n = 5
"#;

fn shard_files(s: &Sweep, n: u64) -> Vec<(String, ShardFile)> {
    (0..n)
        .map(|i| {
            let sh = Shard::new(i, n).unwrap();
            (format!("s{i}"), ShardFile::new(s, sh, run_shard(s, sh).unwrap(), 0.0, 1).unwrap())
        })
        .collect()
}

/// The grid is row-major with the first axis slowest; position and index invert each other.
#[test]
fn grid_order_and_shards() {
    let s = parse(CHART).unwrap();
    assert_eq!(s.cells(), 2 * 4 * 5);
    assert_eq!(s.values(0), vec![25.0, 0.0, 0.0]);
    assert_eq!(s.values(1), vec![25.0, 0.0, 10.0]);
    assert_eq!(s.values(5), vec![25.0, 8.0 / 3.0, 0.0]);
    assert_eq!(s.values(20), vec![30.8, 0.0, 0.0]);
    for k in 0..s.cells() {
        assert_eq!(s.index_of(&s.position(k)), k);
    }
    let sh: Vec<u64> = s.shard_cells(Shard::new(2, 3).unwrap()).collect();
    assert_eq!(sh[..3], [2, 5, 8]);
    // The shards partition the grid.
    let mut all: Vec<u64> = (0..3).flat_map(|i| s.shard_cells(Shard::new(i, 3).unwrap()).collect::<Vec<_>>()).collect();
    all.sort();
    assert_eq!(all, (0..s.cells()).collect::<Vec<_>>());
}

/// Chart cells are the chart's grid points, bit for bit (the exact reference:
/// `scene_chart`), and merging any number of shards gives the one-shard result.
#[test]
fn chart_cells_are_the_charts_points_and_merge_is_shard_independent() {
    let s = parse(CHART).unwrap();
    let scene = Scene::load("furuta-dt25", &[]).unwrap();
    let (chart, _) = sim::stability::scene_chart(&scene, &[25.0, 30.8], (0.0, 40.0, 5), (0.0, 8.0, 4)).unwrap();
    let (one, _) = merge(shard_files(&s, 1)).unwrap();
    for c in &one.cells {
        let p = s.position(c.index);
        let panel = &chart.panels[p[0]];
        let at = p[1] * 5 + p[2];
        assert_eq!(c.radius.unwrap().to_bits(), panel.radius[at].to_bits(), "cell {}", c.index);
        assert_eq!(c.kind.unwrap().crossing(), panel.unstable_kind[at]);
    }
    let stable = one.cells.iter().filter(|c| c.kind == Some(PointKind::Stable)).count();
    assert_eq!(stable, chart.panels.iter().map(|p| p.summary.stable_points).sum::<usize>());
    assert!(stable > 0 && stable < one.cells.len());
    for n in [2, 3, 7] {
        let (m, stats) = merge(shard_files(&s, n)).unwrap();
        assert_eq!(m, one, "{n} shards");
        assert_eq!(stats.shards, n as u32);
        assert_eq!(m.to_csv(), one.to_csv());
    }
}

/// Basin cells are `outcome_of` full-system runs from the displaced start; the small start
/// at 30.5 ms stays bounded and the large one at 31.8 ms escapes.
#[test]
fn basin_cells_are_full_system_outcomes() {
    let s = parse(BASIN).unwrap();
    let (one, _) = merge(shard_files(&s, 1)).unwrap();
    assert_eq!(one.cells.len(), 6);
    for c in &one.cells {
        let tr =
            furuta::full_system::run(c.values[0], &([c.values[1], 0.0, 0.0, 0.0], None), 300, ESCAPE_THETA).unwrap();
        let o = outcome_of(&tr);
        assert_eq!(c.bounded, Some(o.bounded()));
        assert_eq!(c.escape_t, o.escape_t);
        assert_eq!(c.max_theta.map(f64::to_bits), Some(o.max_theta.to_bits()));
    }
    assert_eq!(one.cells[0].bounded, Some(true));
    let (m, _) = merge(shard_files(&s, 4)).unwrap();
    assert_eq!(m, one);
    assert_eq!(one.to_csv().lines().next().unwrap(), "index,dt_ms,theta0,bounded,escape_t,max_theta");
}

/// Per-cell noise seeds come from the cell, so a noisy sweep merges to the same result
/// whatever the shard count; a seed axis sets the seed itself.
#[test]
fn noisy_cells_do_not_depend_on_the_shard() {
    let spec = r#"
name = "q"
kind = "basin"
scene = "furuta-quant-dt25-noise"
set = ["run.periods=200"]
[[axes]]
name = "h_adc"
values = [1e-3, 4e-3]
[[axes]]
name = "theta0"
values = [0.05, 0.1]
"#;
    let s = parse(spec).unwrap();
    let (one, _) = merge(shard_files(&s, 1)).unwrap();
    let (two, _) = merge(shard_files(&s, 3)).unwrap();
    assert_eq!(one, two);
    let seeded =
        parse(&spec.replace("name = \"theta0\"\nvalues = [0.05, 0.1]", "name = \"seed\"\nvalues = [1, 2]")).unwrap();
    let c = seeded.compute(1).unwrap();
    let scene = SceneBuilder::load("furuta-quant-dt25-noise")
        .unwrap()
        .periods(200)
        .quant_step(1e-3)
        .noise_seed(2)
        .escape_theta(ESCAPE_THETA)
        .build()
        .unwrap();
    let o = outcome_of(&simulate(&scene, None).unwrap());
    assert_eq!(c.max_theta.map(f64::to_bits), Some(o.max_theta.to_bits()));
}

fn spec_modes() -> String {
    r#"
name = "m"
kind = "basin"
scene = "furuta-dt30.5"
[[axes]]
name = "slow_amp"
values = [0.0, 0.01]
[[axes]]
name = "fast_amp"
values = [0.0, 0.01]
[basin]
periods = 100
"#
    .to_string()
}

#[test]
fn mode_starts_use_the_cells_own_loop() {
    let s = parse(&spec_modes()).unwrap();
    // Neither mode: the loop at rest stays exactly at the equilibrium.
    let rest = s.compute(0).unwrap();
    assert_eq!((rest.bounded, rest.max_theta), (Some(true), Some(0.0)));
    let err = parse(&spec_modes().replace("values = [0.0, 0.01]\n[[axes]]", "values = [-0.01]\n[[axes]]"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("`axes[0]` (slow_amp): amplitude -0.01 is negative"), "{err}");
    let c = s.compute(3).unwrap();
    let (x, h) = furuta::parametric::mode_start(30.5, Some((0.01, 0.0)), Some((0.01, 0.0))).unwrap();
    let scene = SceneBuilder::load("furuta-dt30.5")
        .unwrap()
        .periods(100)
        .initial_state(&x)
        .history(Some(&h))
        .escape_theta(ESCAPE_THETA)
        .build()
        .unwrap();
    let o = outcome_of(&simulate(&scene, None).unwrap());
    assert_eq!(c.max_theta.map(f64::to_bits), Some(o.max_theta.to_bits()));
}

fn err(text: &str) -> String {
    parse(text).unwrap_err().to_string()
}

#[test]
fn bad_specs_are_errors_naming_the_problem() {
    let e = err(&BASIN.replace("name = \"theta0\"", "name = \"theta9\""));
    assert!(e.contains("axes[1]") && e.contains("unknown axis `theta9`") && e.contains("dt_ms, kp"), "{e}");
    let e = err(&CHART.replace("name = \"kd\"", "name = \"theta0\""));
    assert!(e.contains("axis `theta0` does not apply to a chart sweep"), "{e}");
    let e = err(&BASIN.replace("n = 3", "n = 0"));
    assert!(e.contains("`axes[1]` (theta0)") && e.contains("empty range"), "{e}");
    let e = err(&BASIN.replace("lo = 0.02", "lo = 0.5"));
    assert!(e.contains("empty range: lo = 0.5, hi = 0.3"), "{e}");
    let e = err(&BASIN.replace("values = [30.5, 31.8]", "values = []"));
    assert!(e.contains("`axes[0]` (dt_ms)") && e.contains("empty range"), "{e}");
    let e = err(&BASIN.replace("name = \"theta0\"", "name = \"dt_ms\""));
    assert!(e.contains("given twice"), "{e}");
    let e = err(&BASIN.replace("kind = \"basin\"", "kind = \"basin\"\ncolor = 1"));
    assert!(e.contains("unknown field `color`"), "{e}");
    let e = err(&BASIN.replace("furuta-dt30.5", "no-such-scene"));
    assert!(e.contains("`scene`") && e.contains("no-such-scene"), "{e}");
    let e = err(&CHART.replace("lo = 0.0\nhi = 40.0\nn = 5", "values = [1.0, 2.0]"));
    assert!(e.contains("needs `kp` as a range"), "{e}");
    let e = err(&BASIN.replace("name = \"dt_ms\"\nvalues = [30.5, 31.8]", "name = \"seed\"\nvalues = [1]"));
    assert!(e.contains("axis `seed` needs a scene with [effects.noise]"), "{e}");
    let e = err(&BASIN.replace("kind = \"basin\"", "kind = \"basin\"\nrecord = [\"radius\"]"));
    assert!(e.contains("`radius` is not recorded by a basin sweep"), "{e}");
    let e = err(&BASIN.replace("kind = \"basin\"", "kind = \"basin\"\nshards = 0"));
    assert!(e.contains("`shards`"), "{e}");
    assert!(Shard::parse("8/8").unwrap_err().to_string().contains("shard index 8 outside 0..8"));
    assert!(Shard::parse("1/0").unwrap_err().to_string().contains("shard count 0"));
    assert!(Shard::parse("x").unwrap_err().to_string().contains("expected I/N"));
}

#[test]
fn bad_merges_are_errors_naming_the_shard_or_cell() {
    let s = parse(CHART).unwrap();
    let files = shard_files(&s, 3);
    let e = merge(files[..2].to_vec()).unwrap_err().to_string();
    assert!(e.contains("missing shard 2/3 of spec `c`"), "{e}");
    let mut dup = files.clone();
    dup.push(("again".into(), files[1].1.clone()));
    let e = merge(dup).unwrap_err().to_string();
    assert!(e.contains("shard 1/3 appears twice: s1 and again"), "{e}");
    let other = parse(&CHART.replace("n = 5", "n = 6")).unwrap();
    let mut mixed = files.clone();
    mixed[2] = ("foreign".into(), shard_files(&other, 3).remove(2).1);
    let e = merge(mixed).unwrap_err().to_string();
    assert!(e.contains("shards of two specs") && e.contains("foreign"), "{e}");
    let mut counts = files.clone();
    counts[2] = ("two".into(), shard_files(&s, 4).remove(2).1);
    assert!(merge(counts).unwrap_err().to_string().contains("two shard counts"));
    let mut lost = files.clone();
    lost[1].1.cells.remove(0);
    let e = merge(lost).unwrap_err().to_string();
    assert!(e.contains("s1: cell 1 (dt_ms = 25, kd = 0, kp = 10) is missing"), "{e}");
    let mut twice = files.clone();
    let c = twice[0].1.cells[2].clone();
    twice[0].1.cells.insert(2, c);
    let e = merge(twice).unwrap_err().to_string();
    assert!(e.contains("s0: cell 6 duplicated"), "{e}");
    // A hand-edited spec no longer hashes to the stated hash.
    let mut text = serde_json::to_value(&files[0].1).unwrap();
    text["spec"]["scene"]["controller"]["kp"] = serde_json::json!(16.0);
    let e = ShardFile::parse("x.json", &text.to_string()).unwrap_err().to_string();
    assert!(e.contains("x.json: its spec hashes to"), "{e}");
    // A round trip through JSON keeps the hash and the cells.
    let back = ShardFile::parse("ok.json", &serde_json::to_string(&files[0].1).unwrap()).unwrap();
    assert_eq!(back, files[0].1);
}

/// The bundled example specs parse, with the grids the README describes.
#[test]
fn bundled_example_specs_parse() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/sweeps");
    let mut seen = Vec::new();
    for e in std::fs::read_dir(&dir).unwrap().flatten() {
        let p = e.path();
        if p.extension().is_some_and(|x| x == "toml") {
            let s = Sweep::parse(&p.display().to_string(), &std::fs::read_to_string(&p).unwrap(), &dir).unwrap();
            seen.push((s.name.clone(), s.kind, s.cells()));
        }
    }
    seen.sort_by(|a, b| a.0.cmp(&b.0));
    assert_eq!(
        seen,
        [
            ("basin-dt-theta0".to_string(), Kind::Basin, 72),
            ("basin-modes".into(), Kind::Basin, 81),
            ("chart-cartpole-x".into(), Kind::Chart, 16 * 21),
            ("chart-kp-kd".into(), Kind::Chart, 2 * 33 * 41)
        ]
    );
}

const CARTPOLE: &str = r#"
name = "cp"
kind = "chart"
scene = "cartpole-pd"
[[axes]]
name = "gains.theta.d"
values = [-9.0, -7.0]
[[axes]]
name = "plant.parameters.m"
lo = 0.1
hi = 0.3
n = 3
[[axes]]
name = "gains.x.p"
lo = -30.0
hi = -10.0
n = 3
"#;

/// Named gain and parameter axes: each cell is the stability point of the scene with the
/// same values given as `--set` overrides (an independent path: the scene file's keys).
#[test]
fn named_axes_cells_are_the_overridden_scenes_points() {
    let s = parse(CARTPOLE).unwrap();
    assert_eq!(s.axes[1].name, AxisName::Scene("plant.parameters.m".into()));
    for k in 0..s.cells() {
        let v = s.values(k);
        let o = [
            format!("controller.gains.theta.d={}", v[0]),
            format!("plant.parameters.m={}", v[1]),
            format!("controller.gains.x.p={}", v[2]),
        ];
        let want = sim::stability::scene_point(&Scene::load("cartpole-pd", &o).unwrap()).unwrap();
        let c = s.compute(k).unwrap();
        assert_eq!((c.radius, c.kind), (Some(want.0), Some(PointKind::from(want.1))), "cell {k}");
    }
    // Basin cells run the overridden scene too.
    let b = parse(&format!(
        "{}\n[basin]\nperiods = 50\n",
        CARTPOLE.replace("kind = \"chart\"", "kind = \"basin\"").replace("values = [-9.0, -7.0]", "values = [-7.0]")
    ));
    let b = b.unwrap();
    let c = b.compute(4).unwrap();
    let v = b.values(4);
    let o = [
        format!("controller.gains.theta.d={}", v[0]),
        format!("plant.parameters.m={}", v[1]),
        format!("controller.gains.x.p={}", v[2]),
        "run.periods=50".to_string(),
    ];
    let scene = Scene::load("cartpole-pd", &o).unwrap().builder().escape_theta(b.basin.as_ref().unwrap().escape_theta);
    let o = outcome_of(&simulate(&scene.build().unwrap(), None).unwrap());
    assert_eq!(c.max_theta.map(f64::to_bits), Some(o.max_theta.to_bits()));
    // The shards merge to the one-shard result.
    let one = merge(shard_files(&s, 1)).unwrap();
    let three = merge(shard_files(&s, 3)).unwrap();
    assert_eq!(one.0.cells, three.0.cells);
}

#[test]
fn named_axes_are_checked_against_the_scene() {
    let e = err(&CARTPOLE.replace("gains.x.p", "gains.y.p"));
    assert!(
        e.contains("axes[2]") && e.contains("`y` is not a coordinate") && e.contains("theta.p, theta.d, x.p, x.d"),
        "{e}"
    );
    let e = err(&CARTPOLE.replace("plant.parameters.m", "plant.parameters.mass"));
    assert!(
        e.contains("axes[1]") && e.contains("`mass` is not a parameter") && e.contains("plant.parameters.M"),
        "{e}"
    );
    let e = err(&CARTPOLE.replace("gains.x.p", "theta.d"));
    assert!(e.contains("axes[2]") && e.contains("same quantity as axis `gains.theta.d`"), "{e}");
    let e = err(&CARTPOLE.replace("scene = \"cartpole-pd\"", "scene = \"furuta-dt25\""));
    assert!(e.contains("axes[1]") && e.contains("`plant.params.NAME`"), "{e}");
}

/// A shard file without a version or format is refused in words, naming the file.
#[test]
fn shard_files_without_version_or_format_are_named_in_words() {
    for (text, want) in [
        (r#"{"format": "ssm-sweep-shard"}"#, "version missing"),
        (r#"{"format": "ssm-sweep-shard", "version": "1"}"#, "version missing"),
        (r#"{"format": "ssm-sweep-shard", "version": 99}"#, "version 99;"),
        (r#"{"version": 1}"#, "format missing"),
        (r#"{"format": "other", "version": 1}"#, "format `other` is not"),
    ] {
        let e = ShardFile::parse("s.json", text).unwrap_err().to_string();
        assert!(e.contains("s.json") && e.contains(want), "{text}: {e}");
        assert!(!e.contains("Some(") && !e.contains("None"), "{text}: {e}");
    }
}
