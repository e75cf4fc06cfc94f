//! Cuts a QEMU instruction trace (`-singlestep -d exec,nochain`: one `Trace` line per executed
//! instruction) into instances of one interrupt handler, entry to exception return, callees
//! included, and charges each the cycle model of [`super::disasm`].
//!
//! An instance starts at the handler's first instruction and ends after the instruction that
//! returns at call depth 0 (the exception return). Calls (BL/BLX) and returns are judged by
//! where execution went next: a conditional one in a failed IT block falls through.

use super::disasm::{Flow, Insn, Mem, Program, EXCEPTION_ENTRY, EXCEPTION_EXIT};
use std::collections::HashMap;
use std::io::BufRead;
use std::sync::atomic::{AtomicBool, Ordering};

/// One run of the handler.
#[derive(Clone, Copy, Debug, Default)]
pub struct Instance {
    pub instructions: u32,
    /// Modelled cycles, exception entry and exit included (ART hits).
    pub cycles: u32,
    /// The same with every taken branch into flash an ART miss.
    pub cycles_pessimistic: u32,
    /// Bit `k`: marker `k` (a function of interest) ran in this instance.
    pub marks: u32,
    /// A VFP instruction ran (lazy FP stacking would add to the entry).
    pub fp: bool,
    /// Entries into the counted functions ([`Analyzer::count_entries`]).
    pub entries: u32,
}

/// Per-handler analysis state, fed one PC at a time.
pub struct Analyzer<'p> {
    prog: &'p Program,
    entry: u32,
    /// Instruction address -> marker bits (the functions the situations are told by).
    marks: HashMap<u32, u32>,
    /// Instructions executed inside the handler, per function (by symbol address).
    pub per_function: HashMap<u32, u64>,
    pub instances: Vec<Instance>,
    /// PCs the disassembly does not know (0 in a good run).
    pub unknown: u64,
    /// Entries into other vectors while inside (0: the handler is never preempted).
    pub nested: u64,
    pub lines: u64,
    /// With [`Analyzer::keep_pcs`]: executions per PC, over idle instances (no marker) and
    /// over the others, for a line-by-line look at where a tick goes.
    pub pcs_idle: HashMap<u32, u64>,
    pub pcs_busy: HashMap<u32, u64>,
    /// With [`Analyzer::keep_pcs`]: the PCs of the longest instance (modelled cycles), in
    /// execution order, for a look at what the worst tick ran.
    pub pcs_longest: Vec<u32>,
    longest_cycles: u32,
    keep_pcs: bool,
    /// First instructions of the functions whose calls [`Instance::entries`] counts.
    entry_pcs: std::collections::HashSet<u32>,
    current: Option<Current>,
}

struct Current {
    inst: Instance,
    depth: u32,
    /// The instruction executed last, settled when the next PC shows whether it branched.
    pending: (u32, Insn),
    after_single: bool,
    pcs: Vec<u32>,
}

impl<'p> Analyzer<'p> {
    /// `markers`: for each bit, patterns of function names (demangled, `::h...` stripped; a
    /// name matches when it contains a pattern) whose instructions, or the instructions they
    /// were inlined into, set it.
    pub fn new(prog: &'p Program, entry: u32, markers: &[&[&str]]) -> Self {
        let mut marks = HashMap::new();
        for (bit, names) in markers.iter().enumerate() {
            let hit = |n: &str| names.iter().any(|m| n.contains(m));
            for s in prog.symbols() {
                if hit(&s.name) {
                    for a in (s.addr..s.addr + s.size).step_by(2) {
                        *marks.entry(a).or_insert(0) |= 1 << bit;
                    }
                }
            }
            for (&a, chain) in &prog.inline_names {
                if chain.iter().any(|n| hit(n)) {
                    *marks.entry(a).or_insert(0) |= 1 << bit;
                }
            }
        }
        Analyzer {
            prog,
            entry,
            marks,
            per_function: HashMap::new(),
            instances: Vec::new(),
            unknown: 0,
            nested: 0,
            lines: 0,
            pcs_idle: HashMap::new(),
            pcs_busy: HashMap::new(),
            pcs_longest: Vec::new(),
            longest_cycles: 0,
            keep_pcs: false,
            entry_pcs: Default::default(),
            current: None,
        }
    }

    /// Also count executions per PC ([`Analyzer::pcs_idle`], [`Analyzer::pcs_busy`]).
    pub fn keep_pcs(mut self, yes: bool) -> Self {
        self.keep_pcs = yes;
        self
    }

    /// Counts, per instance, the entries into the out-of-line functions whose names contain
    /// `pattern`; false when there is none.
    pub fn count_entries(&mut self, pattern: &str) -> bool {
        for s in self.prog.symbols() {
            if s.name.contains(pattern) {
                self.entry_pcs.insert(s.addr);
            }
        }
        !self.entry_pcs.is_empty()
    }

    /// Markers whose functions exist in the ELF (a renamed function would silently never mark).
    pub fn marker_found(&self, bit: u32) -> bool {
        self.marks.values().any(|m| m & (1 << bit) != 0)
    }

    /// Reads a whole trace (a FIFO while QEMU writes it), feeding `also` (another handler's
    /// analyzer) the same instructions. After `cap` handler instances it sets `capped` and only
    /// drains the rest, so QEMU never blocks on a full FIFO.
    pub fn read(
        &mut self,
        trace: impl BufRead,
        cap: Option<usize>,
        capped: &AtomicBool,
        also: &mut Analyzer<'_>,
    ) -> std::io::Result<()> {
        let mut last = u32::MAX;
        for line in trace.split(b'\n') {
            let line = line?;
            if cap.is_some_and(|c| self.instances.len() >= c) {
                capped.store(true, Ordering::Relaxed);
                continue;
            }
            let Some(pc) = trace_pc(&line) else { continue };
            self.lines += 1;
            // QEMU logs a block again when it stopped before running it (icount expiry, an
            // interrupt): two identical PCs in a row are one execution.
            if pc == last {
                continue;
            }
            last = pc;
            self.step(pc);
            also.step(pc);
        }
        Ok(())
    }

    fn insn(&mut self, pc: u32) -> Insn {
        match self.prog.insns.get(&pc) {
            Some(i) => *i,
            None => {
                self.unknown += 1;
                Insn {
                    size: 2,
                    flow: Flow::None,
                    mem: Mem::None,
                    base: 1,
                    taken: 0,
                    fp: false,
                    in_flash: true,
                    always: false,
                }
            }
        }
    }

    /// One executed instruction at `pc`.
    pub fn step(&mut self, pc: u32) {
        let Some(mut cur) = self.current.take() else {
            if pc == self.entry {
                let insn = self.insn(pc);
                let mut cur = Current {
                    inst: Instance {
                        cycles: EXCEPTION_ENTRY + EXCEPTION_EXIT,
                        cycles_pessimistic: EXCEPTION_ENTRY + EXCEPTION_EXIT,
                        ..Instance::default()
                    },
                    depth: 0,
                    pending: (pc, insn),
                    after_single: false,
                    pcs: Vec::new(),
                };
                self.count(&mut cur, pc, insn);
                self.current = Some(cur);
            }
            return;
        };
        let (ppc, p) = cur.pending;
        let taken = pc != ppc.wrapping_add(p.size as u32) || p.always;
        cur.inst.cycles += p.cycles(taken, cur.after_single, false);
        cur.inst.cycles_pessimistic += p.cycles(taken, cur.after_single, true);
        cur.after_single = matches!(p.mem, Mem::SingleLoad | Mem::SingleStore);
        if taken {
            match p.flow {
                Flow::Call => cur.depth += 1,
                Flow::Return if cur.depth == 0 => {
                    let to =
                        if cur.inst.marks == 0 { &mut self.pcs_idle } else { &mut self.pcs_busy };
                    for &a in &cur.pcs {
                        *to.entry(a).or_insert(0) += 1;
                    }
                    if self.keep_pcs && cur.inst.marks != 0 && cur.inst.cycles > self.longest_cycles
                    {
                        self.longest_cycles = cur.inst.cycles;
                        self.pcs_longest = std::mem::take(&mut cur.pcs);
                    }
                    self.instances.push(cur.inst);
                    // The PC after the exception return may be the handler again (tail-chain).
                    return self.step_outside(pc);
                }
                Flow::Return => cur.depth -= 1,
                _ => {}
            }
        }
        if pc != self.entry && self.prog.vectors.contains(&pc) && cur.depth == 0 && taken {
            self.nested += 1;
        }
        let insn = self.insn(pc);
        cur.pending = (pc, insn);
        self.count(&mut cur, pc, insn);
        self.current = Some(cur);
    }

    fn step_outside(&mut self, pc: u32) {
        self.current = None;
        if pc == self.entry {
            self.step(pc);
        }
    }

    fn count(&mut self, cur: &mut Current, pc: u32, insn: Insn) {
        cur.inst.instructions += 1;
        if self.keep_pcs {
            cur.pcs.push(pc);
        }
        cur.inst.fp |= insn.fp;
        if let Some(m) = self.marks.get(&pc) {
            cur.inst.marks |= m;
        }
        if self.entry_pcs.contains(&pc) {
            cur.inst.entries += 1;
        }
        let f = self.prog.symbol_at(pc).map_or(pc, |s| s.addr);
        *self.per_function.entry(f).or_insert(0) += 1;
    }
}

/// The guest PC of a `Trace` line: `Trace 0: 0x7f.. [00800408/08010000/00000110/ff020201] sym`.
fn trace_pc(line: &[u8]) -> Option<u32> {
    if !line.starts_with(b"Trace ") {
        return None;
    }
    let open = line.iter().position(|&b| b == b'[')?;
    let field = line.get(open + 10..open + 18)?;
    let text = std::str::from_utf8(field).ok()?;
    u32::from_str_radix(text, 16).ok()
}

#[cfg(test)]
mod tests {
    use super::super::disasm::parse_disassembly;
    use super::*;

    fn program(asm: &str) -> Program {
        Program::from_parts(parse_disassembly(asm), vec![], vec![0; 64])
    }

    #[test]
    fn an_instance_runs_from_entry_to_the_return_at_depth_zero() {
        // handler: push; bl f; pop {pc}    f: adds; bx lr
        let asm = " 8000000:\tpush\t{r4, lr}\n 8000002:\tbl\t0x8000010\n \
                   8000006:\tpop\t{r4, pc}\n 8000008:\tnop\n 8000010:\tadds\tr0, r0, r1\n \
                   8000012:\tbx\tlr\n 8000014:\tnop\n";
        let prog = program(asm);
        let mut a = Analyzer::new(&prog, 0x0800_0000, &[]);
        for pc in [0x0900_0000, 0x0800_0000, 0x0800_0002, 0x0800_0010, 0x0800_0012, 0x0800_0006] {
            a.step(pc);
        }
        // Still inside: the pop is settled by the next PC.
        assert!(a.instances.is_empty());
        a.step(0x0900_0004);
        assert_eq!(a.instances.len(), 1);
        let i = a.instances[0];
        assert_eq!(i.instructions, 5);
        // push 3, bl 1+2, adds 1, bx 1+2, pop 3+2, entry/exit 22
        assert_eq!(i.cycles, 3 + 3 + 1 + 3 + 5 + EXCEPTION_ENTRY + EXCEPTION_EXIT);
    }

    #[test]
    fn a_conditional_return_that_falls_through_does_not_end_it() {
        let asm = " 8000000:\tcmp\tr0, #0\n 8000002:\tit\teq\n 8000004:\tbxeq\tlr\n \
                   8000006:\tbx\tlr\n 8000008:\tnop\n";
        let prog = program(asm);
        let mut a = Analyzer::new(&prog, 0x0800_0000, &[]);
        for pc in [0x0800_0000, 0x0800_0002, 0x0800_0004, 0x0800_0006, 0x0900_0000] {
            a.step(pc);
        }
        assert_eq!(a.instances.len(), 1);
        assert_eq!(a.instances[0].instructions, 4);
    }

    #[test]
    fn a_return_that_tail_chains_into_the_handler_placed_next_ends_it() {
        // handler: pop {pc}; the next handler's first instruction right after it.
        let asm = " 8000000:\tpush\t{r4, lr}\n 8000002:\tpop\t{r4, pc}\n \
                   8000004:\tpush\t{r4, lr}\n 8000006:\tnop\n";
        let prog = program(asm);
        let mut a = Analyzer::new(&prog, 0x0800_0000, &[]);
        for pc in [0x0800_0000, 0x0800_0002, 0x0800_0004, 0x0800_0006] {
            a.step(pc);
        }
        assert_eq!(a.instances.len(), 1);
        assert_eq!(a.instances[0].instructions, 2);
    }

    #[test]
    fn trace_lines_give_their_guest_pc() {
        let line = b"Trace 0: 0x7fdff8000100 [00800408/08010000/00000110/ff020201] Reset";
        assert_eq!(trace_pc(line), Some(0x0801_0000));
        assert_eq!(trace_pc(b"Stopped execution of TB chain before 0x7f"), None);
    }
}
