//! `ssmctl`: the command line over the simulator (`sim`), the SSM learner (`ssm`), the chaos
//! estimators (`chaos`) and the paper's study (`furuta`); the report and its figures, the
//! accuracy-vs-time benches, and the host side of processor-in-the-loop runs. The only crate
//! of the workspace that depends on clap, indicatif and plotters.

pub mod bench;
pub mod child;
pub mod cli;
pub mod draw;
pub mod equations_command;
pub mod fit_command;
pub mod output;
pub mod perf;
pub mod pil;
pub mod plot;
pub mod report;
pub mod study;
pub mod sweep;
