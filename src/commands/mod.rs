//! The subcommands, one module each, and what they share: the data files
//! (`data`) and the printed output (`output`).

pub mod adapt;
pub mod collect;
pub mod data;
pub mod demo;
pub mod eval;
pub mod output;
pub mod serial;
pub mod tradeoff;
pub mod train;
