//! Host side of the motion board: job files (TOML and G-code) to planner moves, offline planning
//! through the host model of the firmware, and the command-line tool's pieces.
//!
//! Pipeline: [`job::parse_toml`] or [`gcode::load`] (G-code through `motion-gcode`) -> [`job::Job`] -> [`convert::convert`] ->
//! [`convert::Program`] -> [`plan::Stream`] (segments and events) -> a link ([`transport`],
//! [`link`], [`runner`]) or the host model ([`plan::simulate`]).

pub mod board_link;
pub mod capabilities;
pub mod cli;
pub mod convert;
pub mod csv_log;
pub mod gcode;
pub mod grbl;
pub mod homing;
pub mod job;
pub mod journal;
pub mod link;
pub mod milling;
pub mod noise;
pub mod out;
pub mod outputs;
pub mod plan;
pub mod plan_figure;
pub mod plot;
pub mod polar;
pub mod progress;
pub mod qemu;
pub mod runner;
pub mod sample_job;
pub mod sim_board;
pub mod sim_link;
pub mod toml_run;
pub mod transport;
pub mod turning;
pub mod units;
pub mod wire;
