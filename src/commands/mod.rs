//! Subcommands of the binary that have grown past a few lines.

pub mod serial;
