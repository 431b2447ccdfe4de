//! What a closed-loop run leaves behind: its trace (CSV), the summary figures
//! (JSON) and a plot (PNG).

pub mod plot;
pub mod summary;
pub mod trace;

pub use trace::TraceRow;
