//! `ssm::auto` on simulated decays of the Furuta loop (the 1.2x test of `ssm`'s
//! `auto_select` on a closed loop with delay and ZOH): at each sampling period of
//! [`FURUTA_SCENES`], runs of the pendulum angle from small initial displacements; auto's
//! held-out NMTE within 1.2x of the smallest of an exhaustive grid over the same options, and
//! its eigenvalue error (against the exact multipliers of the ZOH map, as many pairs as the
//! model's dimension holds) within 1.2x of the grid winner's. A small grid here; the full default grid is the example `auto_table`.

use furuta::auto_sets::{FURUTA_PERIODS, FURUTA_SCENES, FURUTA_THETAS, eigenvalue_error, furuta_decays};
use ssm::auto::{AutoGrid, AutoOptions, exhaustive, select};

fn small_grid() -> AutoGrid {
    AutoGrid {
        cuts: vec![0.0, 0.1],
        embed_extra: vec![0, 2],
        shifts: vec![1, 2],
        manifold_orders: vec![3, 1],
        dyn_orders: vec![5, 3],
        ridges: vec![0.0, 1e-6],
        anchors: vec![None, Some(0.2)],
    }
}

#[test]
fn auto_is_within_1_2x_of_the_exhaustive_grid_on_furuta_decays() {
    for scene in FURUTA_SCENES {
        let set = furuta_decays(scene, &FURUTA_THETAS, FURUTA_PERIODS).unwrap();
        let exact = &set.exact;
        let o = AutoOptions { grid: small_grid(), budget: 40, ..Default::default() };
        let auto = select(&set.train, &o).unwrap();
        let (all, at) = exhaustive(&set.train, &o).unwrap();
        let g = &all[at];
        let min_nmte = all.iter().map(|s| s.nmte).fold(f64::INFINITY, f64::min);
        let err = |s: &ssm::auto::Setting| {
            let m = ssm::fit_multi(&ssm::auto::cut(&set.train, s.cut), &s.options).unwrap();
            eigenvalue_error(&m, exact)
        };
        let (ea, eg) = (err(&auto.best.setting), err(&g.setting));
        eprintln!(
            "{}: exact {:?}; auto {} (NMTE {:.3e}, eig. error {ea:.2e}, {} settings) | grid winner {} (NMTE {:.3e}, eig. error {eg:.2e}) | grid min NMTE {min_nmte:.3e}",
            set.name,
            &exact[..2],
            auto.best.setting.describe(),
            auto.best.nmte,
            auto.evaluated,
            g.setting.describe(),
            g.nmte,
        );
        assert!(auto.evaluated <= 40);
        assert!(auto.best.nmte <= 1.2 * min_nmte, "{}: NMTE {} vs grid best {min_nmte}", set.name, auto.best.nmte);
        assert!(ea <= 1.2 * eg.max(1e-4), "{}: eigenvalue error {ea} vs grid winner {eg}", set.name);
    }
}
