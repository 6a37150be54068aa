//! The tests of the plants: one module per source module of `sim::plant`.

mod cart;
pub(crate) mod equations;
mod furuta;
mod linearize;
