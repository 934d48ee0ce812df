//! Order statistics as box plots draw them: the study crate's, re-exported
//! so evaluation code and its users name them from here.

pub use buridan_study::stats::{quantile, BoxStats};
