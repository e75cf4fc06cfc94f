//! Host oracles for Elbestawi (1980), adaptive constant-force milling: the thesis's static
//! numbers, root loci, pass-by-pass force growth and safe rapid feeds, recomputed in f64 so
//! tests can compare them with the printed values (digest: shared/digest/elbestawi-adaptive-force.md).

pub mod case_a;
pub mod cli;
pub mod figure;
pub mod job;
pub mod pass_growth;
pub mod rapid_feed;
pub mod resume;
pub mod root_locus;
pub mod run;
pub mod sim_board;
pub mod simulate;
pub mod steady;
pub mod summary;
