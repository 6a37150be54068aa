//! `.mat` input end to end, on files made without MATLAB: `tests/data/make_mat.py` writes
//! them with scipy.io.savemat (v5, compressed and not) and h5py (a v7.3/HDF5 file with
//! MATLAB's header), from a simulated damped Duffing oscillator observed through three
//! observables (x, v, x + x^2/2) whose values are also in `duffing_{1,2,3}.csv`.

use std::path::PathBuf;
use std::time::Instant;

use ssm::data::{DataError, MultiSeries, load_csv_observables, load_mat};
use ssm::mat::MatError;
use ssm::{Dynamics, FitOptions, Ridge, fit_multi};

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

fn csv(i: usize) -> MultiSeries {
    load_csv_observables(data(&format!("duffing_{i}.csv")), None).unwrap()
}

/// Golden test: every value the reader returns equals, bit for bit, the CSV value the file
/// was built from (compressed file with row-vector times; uncompressed file with
/// column-vector times after a char variable the reader skips).
#[test]
fn mat_values_equal_the_csv_they_were_built_from() {
    for file in ["duffing.mat", "duffing_plain.mat"] {
        let trajs = load_mat(data(file), "xData").unwrap();
        assert_eq!(trajs.len(), 3, "{file}");
        for (i, tr) in trajs.iter().enumerate() {
            let c = csv(i + 1);
            assert_eq!(tr.observables, ["1", "2", "3"]);
            assert_eq!(c.observables, ["x", "v", "x2"]);
            assert_eq!((tr.t.len(), tr.dim()), (301, 3));
            assert!(tr.t.iter().zip(&c.t).all(|(a, b)| a.to_bits() == b.to_bits()), "{file} t of trajectory {i}");
            assert!(tr.x.iter().zip(&c.x).all(|(a, b)| a.to_bits() == b.to_bits()), "{file} X of trajectory {i}");
            assert!(tr.name.ends_with(&format!("xData{{{},:}}", i + 1)), "{}", tr.name);
        }
    }
}

/// Bad files: each error names the variable, the cell or the trajectory, and what to do.
#[test]
fn mat_errors_name_variable_cell_and_trajectory() {
    let err = |file: &str, var: &str| load_mat(data(file), var).unwrap_err();
    let e = err("mismatch.mat", "xData");
    assert!(matches!(&e, DataError::ObservableMismatch { name, .. } if name.ends_with("xData{2,:}")), "{e}");
    assert!(e.to_string().contains("[1, 2]") && e.to_string().contains("[1, 2, 3]"), "{e}");
    let e = err("transposed.mat", "xData").to_string();
    assert!(e.contains("xData{1,2}") && e.contains("X is 301 x 3") && e.contains("transpose"), "{e}");
    let e = err("notcell.mat", "xData").to_string();
    assert!(e.contains("xData: a double array; expected a cell array"), "{e}");
    let e = err("duffing.mat", "yData");
    assert!(
        matches!(&e, DataError::Mat(MatError::NoVariable { .. })) && e.to_string().contains("variables: xData"),
        "{e}"
    );
    let e = err("v73.mat", "xData");
    assert!(matches!(&e, DataError::Mat(MatError::V73 { .. })), "{e}");
    assert!(e.to_string().contains("v7.3 (HDF5)") && e.to_string().contains("'-v7'"), "{e}");
    let e = err("no_such_file.mat", "xData").to_string();
    assert!(e.contains("no_such_file.mat: cannot read"), "{e}");
}

/// A 2D SSM fitted to three observables of the Duffing oscillator read from the .mat file
/// (two copies of each: 6 coordinates), trained on trajectories 1 and 3, tested on 2, after
/// cutting the first 0.5 s (`window`). NMTE over all three observables.
#[test]
fn fits_several_observables_from_a_mat_file() {
    let trajs: Vec<MultiSeries> = load_mat(data("duffing.mat"), "xData")
        .unwrap()
        .iter()
        .map(|t| t.window(Some(0.5), None))
        .collect::<Result<_, _>>()
        .unwrap();
    let train = [trajs[0].clone(), trajs[2].clone()];
    let opts = FitOptions {
        dim: 2,
        embed: 2,
        shift: 1,
        manifold_order: 3,
        dyn_order: 5,
        dynamics: Dynamics::Map,
        ridge: Ridge::Fixed(0.0),
        linear_anchor: None,
        anchor_joint: false,
    };
    let t0 = Instant::now();
    let model = fit_multi(&train, &opts).unwrap();
    let fit_ms = t0.elapsed().as_secs_f64() * 1e3;
    assert_eq!((model.observables, model.manifold.p), (3, 6));
    let pred = model.predict_multi(&trajs[1]).unwrap();
    assert!(pred.stop.is_none());
    assert_eq!(pred.x.len(), trajs[1].x.len());
    let nmte = pred.nmte_multi(&trajs[1]);
    let per_obs: Vec<f64> = (0..3)
        .map(|i| {
            let p: Vec<f64> = pred.x.iter().skip(i).step_by(3).copied().collect();
            ssm::metrics::nmte(&p, &trajs[1].observable(i).unwrap().x, 1).unwrap()
        })
        .collect();
    eprintln!(
        "duffing.mat, 3 observables x 2 copies, map order 5: fit {fit_ms:.2} ms, test NMTE {nmte:.2e} (per observable {per_obs:?})"
    );
    assert!(nmte < 1e-2, "test NMTE {nmte}");
    // A one-observable test series does not fit a three-observable model.
    let e = model.predict(&trajs[1].observable(0).unwrap()).unwrap_err();
    assert!(e.to_string().contains("1 observables, the model was fitted to 3"), "{e}");
    // Too few coordinates for 2 d: one copy of two observables.
    let two: Vec<MultiSeries> = train.iter().map(|t| t.select(&["1".into(), "3".into()]).unwrap()).collect();
    let e = fit_multi(&two, &FitOptions { embed: 1, ..opts }).unwrap_err();
    assert!(e.to_string().contains("1 copies of 2 observables = 2 coordinates must exceed 2 d = 4"), "{e}");
    // Mixed observable counts in the training set name the trajectory.
    let e = fit_multi(&[train[0].clone(), two[1].clone()], &opts).unwrap_err();
    assert!(e.to_string().contains("xData{3,:}") && e.to_string().contains("differ from those of"), "{e}");
}
