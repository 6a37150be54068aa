use super::*;

/// A quasi-periodic signal (two incommensurate frequencies: a 2-torus, whose delay
/// embeddings need 4 dimensions to be one-to-one in general): projected on its first two
/// singular directions most nearest neighbours are false, on four none (ratio 10).
#[test]
fn projection_fnn_finds_the_torus_dimension() {
    let x: Vec<f64> = (0..4000).map(|i| (0.21 * i as f64).sin() + 0.6 * (0.21 * 0.5f64.sqrt() * 5.1 * i as f64).cos()).collect();
    let rows = projection_fnn(&x, 8, 2, 30, &[1, 2, 4, 6], 10.0, 400).unwrap();
    println!("{rows:?}");
    assert_eq!(rows.iter().map(|r| r.dim).collect::<Vec<_>>(), vec![1, 2, 4, 6]);
    assert!(rows[0].fnn > 0.5 && rows[1].fnn > 0.2, "{rows:?}");
    assert_eq!(rows[2].fnn, 0.0, "{rows:?}");
    assert_eq!(rows[3].fnn, 0.0, "{rows:?}");
    assert!((rows[0].singular_rel - 1.0).abs() < 1e-12 && rows.windows(2).all(|w| w[1].singular_rel <= w[0].singular_rel), "{rows:?}");
    assert!(projection_fnn(&x, 8, 2, 30, &[8], 10.0, 400).is_err());
    assert!(projection_fnn(&x[..50], 8, 2, 30, &[2], 10.0, 400).is_err());
}

/// The dimension rule on the same torus: `p = 2 d + 1` for each `d` until the projection has
/// no false neighbours (ratio 2); a sine (a circle) needs 2.
#[test]
fn fnn_dimension_rule() {
    let x: Vec<f64> = (0..4000).map(|i| (0.21 * i as f64).sin() + 0.6 * (0.21 * 0.5f64.sqrt() * 5.1 * i as f64).cos()).collect();
    let (d, rows) = fnn_dimension(&x, 2, 30, 2.0, 0.005, 6, 400).unwrap();
    println!("{rows:?}");
    assert_eq!(rows.len(), d.unwrap());
    assert!((3..=4).contains(&d.unwrap()), "{rows:?}");
    assert!(rows.last().unwrap().fnn <= 0.005 && rows[..rows.len() - 1].iter().all(|r| r.fnn > 0.005), "{rows:?}");
    let s: Vec<f64> = (0..3000).map(|i| (0.13 * i as f64).sin()).collect();
    let (d, _) = fnn_dimension(&s, 3, 50, 2.0, 0.005, 4, 300).unwrap();
    assert_eq!(d, Some(2));
    let (none, rows) = fnn_dimension(&x, 2, 30, 2.0, 0.005, 1, 400).unwrap();
    assert!(none.is_none() && rows.len() == 1);
}

/// The map class on the true state reproduces its committed diagnosis row: the quartic map
/// on x1..x4 of the known system (noise-free, the flag's data amount) has Benettin 0.931 1/s
/// (0.99 of the exact exponent), Rosenstein 0.342, D2 2.72, JS 0.0062.
#[test]
fn state_model_reproduces_its_committed_row() {
    let fit = StateFit { coords: Coords::State, centers: 0, order: 4, ridge: 3e-9, multistep: None, noise_rel: 0.0 };
    let (k, r) = state_model_check(&crate::flag_pipeline::CHOSEN, &crate::flag_pipeline::FLAG_LAYOUT, 1, &fit, 4000.0).unwrap();
    let committed = diagnosis_rows().into_iter().find(|(_, _, c)| c.candidate == "state poly 4").unwrap().2;
    for (a, b, tol) in [(r.benettin, committed.benettin, 5e-4), (r.rosenstein, committed.rosenstein, 5e-4), (r.corr_dim, committed.corr_dim, 5e-3), (r.js, committed.js, 5e-5)] {
        let (a, b) = (a.unwrap(), b.unwrap());
        assert!((a - b).abs() <= tol, "{r:?} vs {committed:?}");
    }
    assert!(r.failed.is_none() && r.benettin_exact_ok && (k.exact - 0.940).abs() < 0.02, "{r:?}");
    let bad = StateFit { coords: Coords::Delay { embed: 0, shift: 1 }, ..fit };
    assert!(state_model_check(&crate::flag_pipeline::CHOSEN, &crate::flag_pipeline::FLAG_LAYOUT, 1, &bad, 100.0).unwrap_err().to_string().contains("delay"));
}

/// What the committed diagnosis says: with the flag's settings on noise-free data no
/// candidate comes within 10 % of the exact exponent; on the true state every noise-free
/// fit does (0.92-1.08); with SSM dimension 6 (the dimension rule's choice) four of the five
/// RBF sizes at the flag's noise and data amount do, two of five at three times the data,
/// none of three on noise-free data (the noise regularizes the small singular directions);
/// denoised inputs none of five; on the flag no d = 5 or 6 row meets a target.
#[test]
fn diagnosis_counts() {
    let rows = diagnosis_rows();
    let within = |what: &str, noise: Option<f64>, scale: usize| {
        let sel: Vec<_> = rows.iter().filter(|(w, n, r)| *w == what && noise.is_none_or(|x| *n == x) && r.scale == scale).collect();
        (sel.iter().filter(|(_, _, r)| r.benettin_exact_ok).count(), sel.len())
    };
    assert_eq!(within("(a) noise-free", None, 1), (0, 6));
    assert_eq!(within("(c) true state", Some(0.0), 1), (4, 4));
    assert_eq!(within("(b) d = 6", Some(FN), 1), (4, 5));
    assert_eq!(within("(b) d = 6", Some(FN), 3), (2, 5));
    assert_eq!(within("(b) d = 6", Some(0.0), 1), (0, 3));
    assert_eq!(within("(b) d = 5", None, 1), (1, 6));
    assert_eq!(within("denoised inputs", None, 1), (0, 5));
    assert_eq!(within("ridge", None, 1), (0, 9));
    assert_eq!(within("multistep", None, 1), (1, 2));
    // The multistep scan at d = 6 (Benettin within 10 %, also JS <= 0.01, rows): at 1x and the
    // flag's noise 4 of 13 multistep rows against 4 of 9 one-step rows, none with JS <= 0.01;
    // the one-step RBF 250 loses its chaos on seeds 1 and 2 where multistep keeps it (0.87 and
    // 1.18 of exact); at 3x the data the refined RBF 250 is not chaotic (the one-step one reads
    // 0.94 of exact); noise-free neither.
    assert_eq!(d6_scan_counts(&rows, true, 1, FN), (4, 0, 13));
    assert_eq!(d6_scan_counts(&rows, false, 1, FN), (4, 0, 9));
    assert_eq!(d6_scan_counts(&rows, true, 3, FN), (0, 0, 1));
    assert_eq!(d6_scan_counts(&rows, false, 3, FN), (2, 0, 5));
    assert_eq!(d6_scan_counts(&rows, true, 1, 0.0), (0, 0, 2));
    assert_eq!(d6_scan_counts(&rows, false, 1, 0.0), (0, 0, 3));
    // On the flag, SSM dimension 5 and 6 meet none of the four targets.
    let flag = flag_fit_rows();
    assert_eq!(flag.len(), 9);
    assert!(flag.iter().all(|r| r.passes == [false; 4]), "{flag:?}");
}

/// Multistep refinement on the flag (committed rows): no row meets more than one target; the
/// Benettin target only RBF 300 at d = 4 (0.326 against the data's 0.332), JS only RBF 200 at
/// d = 4 with horizon 4 (0.0092); D2 is at most 2.14 against 3.36 ± 0.17 and Rosenstein at
/// most 0.241 against 0.332.
#[test]
fn flag_multistep_rows_meet_at_most_one_target() {
    let rows = flag_multistep_rows();
    assert_eq!(rows.len(), FLAG_MULTISTEP.len());
    assert!(rows.iter().all(|r| r.passes.iter().filter(|&&p| p).count() <= 1), "{rows:?}");
    let meets = |i: usize| rows.iter().filter(|r| r.passes[i]).map(|r| r.candidate.as_str()).collect::<Vec<_>>();
    assert_eq!(meets(0), vec!["RBF 300 r=3e-9 d=4 p=9 ms h=4 stride 8 it 4"]);
    assert!(meets(1).is_empty() && meets(2).is_empty());
    assert_eq!(meets(3), vec!["RBF 200 r=3e-9 d=4 p=9 ms h=4 stride 8 it 4"]);
    let max = |f: &dyn Fn(&PipelineRow) -> Option<f64>| rows.iter().filter_map(f).fold(f64::MIN, f64::max);
    assert!((max(&|r| r.corr_dim) - 2.14).abs() < 1e-12 && (max(&|r| r.rosenstein) - 0.241).abs() < 1e-12);
    assert_eq!(rows.iter().filter(|r| r.failed.is_some()).count(), 1);
}
