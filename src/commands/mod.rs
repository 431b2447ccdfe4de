//! Subcommands of the binary that have grown past a few lines: `demo`,
//! `tradeoff`, and the serial tools `biotac-emulator` and `biotac-monitor`.

pub mod demo;
pub mod serial;
pub mod tradeoff;
