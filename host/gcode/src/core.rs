//! The interpreter's state and its output queue, shared by the modules that run blocks.

use crate::canon::{Call, Canon};
use crate::diag::{At, Fault, GrblHabit, Kind, Res};
use crate::params::Params;
use crate::state::Settings;
use crate::world::{ToolTable, World};
use std::collections::VecDeque;

/// Limits that keep a program from running forever or flooding memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Jumps back of one loop (while, do, repeat) before it is stopped.
    pub max_loop_iterations: u64,
    /// Canonical calls one block may make (a canned cycle with a huge L or a tiny peck).
    pub max_calls_per_block: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits { max_loop_iterations: 10_000_000, max_calls_per_block: 1_000_000 }
    }
}

/// How the interpreter reads a program.
#[derive(Clone, Debug)]
pub struct Options {
    /// The tool table (default: tools 1..=20, no offsets, as the reference rs274 runs).
    pub tools: ToolTable,
    /// Numbered parameters at start, as a LinuxCNC `.var` file gives them (`5220 = 1`).
    pub parameters: Vec<(usize, f64)>,
    /// Skip lines starting with `/` (block delete switch on). rs274 runs with it off.
    pub block_delete: bool,
    /// Accept grbl habits (no program end, sender lines, out-of-plane zero arc offsets, long
    /// lines) with a warning instead of rs274's error.
    pub grbl_habits: bool,
    pub limits: Limits,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            tools: ToolTable::default(),
            parameters: vec![(5220, 1.0)],
            block_delete: false,
            grbl_habits: true,
            limits: Limits::default(),
        }
    }
}

impl Options {
    /// Exactly rs274's behaviour: grbl habits are errors.
    pub fn strict() -> Self {
        Options { grbl_habits: false, ..Options::default() }
    }
}

/// A warning raised while running a block (reported with the block's line).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct BlockWarning {
    pub fault: Fault,
}

pub(crate) struct Core {
    pub s: Settings,
    pub params: Params,
    pub world: World,
    pub opts: Options,
    pub out: VecDeque<Call>,
    /// Calls made by the block being run.
    pub emitted: usize,
    pub warnings: Vec<BlockWarning>,
    pub nurbs: crate::spline::Nurbs,
}

impl Core {
    pub fn new(opts: Options) -> Self {
        Core {
            s: Settings::new(opts.tools.clone()),
            params: Params::new(&opts.parameters),
            world: World::new(opts.tools.clone()),
            opts,
            out: VecDeque::new(),
            emitted: 0,
            warnings: Vec::new(),
            nurbs: crate::spline::Nurbs::default(),
        }
    }

    /// Makes a canonical call, tagged with the current line.
    pub fn emit(&mut self, canon: Canon) -> Res<()> {
        self.emitted += 1;
        if self.emitted > self.opts.limits.max_calls_per_block {
            return Err(Fault::limit(
                format!(
                    "this block makes more than {} canonical calls (a canned cycle's L or Q?)",
                    self.opts.limits.max_calls_per_block
                ),
                At::Line,
            ));
        }
        self.world.observe(&canon);
        self.out.push_back(Call { line: self.s.line, canon });
        Ok(())
    }

    /// A grbl habit accepted with a warning.
    pub fn grbl_warning(&mut self, habit: GrblHabit, msg: impl Into<String>, at: At) {
        self.warnings
            .push(BlockWarning { fault: Fault { msg: msg.into(), at, kind: Kind::Grbl(habit) } });
    }
}
