//! The tests of `ssmctl::draw`, a module per source module.

mod basin;
mod chart;
mod portrait;
