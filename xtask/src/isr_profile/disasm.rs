//! The firmware's instructions, with the cycle model the profile charges them.
//!
//! Cycle model (Cortex-M4 Technical Reference Manual, ARM DDI 0439, table 3-1 "Cortex-M4
//! instruction set summary", with its pipelining notes):
//!
//! | instruction | cycles |
//! |---|---|
//! | data processing, MOV, compare, shift, IT, MUL, UMULL/SMULL/UMLAL/SMLAL | 1 |
//! | MLA, MLS | 2 |
//! | SDIV, UDIV | 12 (the TRM's 2..12: the worst case, since operands are not traced) |
//! | LDR (single) | 2; 1 right behind another single load or store (pipelined address phase) |
//! | STR (single) | 1 (the write buffer takes it) |
//! | LDRD, STRD | 3 |
//! | LDM, STM, PUSH, POP, VLDM, VSTM, VPUSH, VPOP | 1 + N registers |
//! | VLDR, VSTR | 2; other VFP | 1 |
//! | branch taken (B, Bcc, CBZ, CBNZ, BL, BX, BLX, writes to PC) | + P = 2 pipeline refill (TRM: 1..3) |
//! | TBB, TBH | 2 + P when taken |
//! | DMB, DSB, ISB | 3 |
//!
//! Exception entry (12 cycles) and exit (10) are charged per interrupt by the caller. Flash wait
//! states: the STM32F405 runs 5 at 168 MHz, hidden by the ART accelerator (prefetch and a 1 KB
//! instruction cache) for code that stays in its cache, as the tick's does at 100 kHz. The
//! profile's main figure assumes ART hits (0 extra); its pessimistic figure charges the 5 wait
//! states on every taken branch into flash (every branch target an ART miss). Code placed in RAM
//! (0x2000_0000..) is charged 0 in both.

use anyhow::{bail, Context, Result};
use std::collections::HashMap;
use std::path::Path;
use std::process::Command;

/// Taken-branch pipeline refill (TRM: 1..3).
pub const REFILL: u32 = 2;
/// Flash wait states at 168 MHz, 3.3 V (RM0090 table 10).
pub const FLASH_WAIT_STATES: u32 = 5;
/// Exception entry and exit with zero-wait-state stacking (TRM 3.3.1 / 5.5).
pub const EXCEPTION_ENTRY: u32 = 12;
pub const EXCEPTION_EXIT: u32 = 10;
const FLASH: std::ops::Range<u32> = 0x0800_0000..0x0810_0000;

/// How an instruction can move the PC.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    /// Falls through.
    None,
    /// May jump (B, Bcc, CBZ, TBB, MOV/ADD PC, LDR PC from a table).
    Branch,
    /// BL, BLX: a call when taken.
    Call,
    /// BX LR, POP {.., PC}, LDR PC, [SP], LDM SP!, {.., PC}: a return when taken (at depth 0:
    /// the exception return).
    Return,
}

/// Memory access class, for the load/store pipelining rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mem {
    None,
    SingleLoad,
    SingleStore,
    Other,
}

#[derive(Clone, Copy, Debug)]
pub struct Insn {
    pub size: u8,
    pub flow: Flow,
    pub mem: Mem,
    /// Cycles when it does not branch.
    pub base: u32,
    /// Extra cycles when it branches (the refill).
    pub taken: u32,
    /// A VFP instruction (the tick must use none: lazy FP stacking would cost 17+ cycles).
    pub fp: bool,
    pub in_flash: bool,
    /// An unconditional transfer (no condition, not `cbz`/`cbnz`): taken even when it lands on
    /// the next address, as an exception return does that tail-chains into a handler placed
    /// right after this one.
    pub always: bool,
}

impl Insn {
    /// Cycles for this execution, `taken` whether control left the fall-through path and
    /// `after_single` whether the previous instruction was a single load or store.
    pub fn cycles(&self, taken: bool, after_single: bool, pessimistic: bool) -> u32 {
        let mut c = self.base;
        if self.mem == Mem::SingleLoad && after_single {
            c = 1;
        }
        if taken {
            c += self.taken;
            if pessimistic && self.in_flash {
                c += FLASH_WAIT_STATES;
            }
        }
        c
    }
}

/// A function symbol.
#[derive(Clone, Debug)]
pub struct Symbol {
    pub addr: u32,
    pub size: u32,
    pub name: String,
}

/// The ELF as the profile needs it.
pub struct Program {
    pub insns: HashMap<u32, Insn>,
    /// Every function an instruction belongs to, its own and those inlined into it
    /// (`path::f`, innermost first), from the ELF's DWARF.
    pub inline_names: HashMap<u32, Vec<String>>,
    symbols: Vec<Symbol>,
    /// Handler address of every vector, by exception number.
    pub vectors: Vec<u32>,
}

impl Program {
    pub fn load(root: &Path, elf: &Path) -> Result<Program> {
        let objdump = crate::setup::llvm_tool(root, "llvm-objdump")?;
        let nm = crate::setup::llvm_tool(root, "llvm-nm")?;
        let asm = run(Command::new(&objdump).args(["-d", "--no-show-raw-insn"]).arg(elf))?;
        let vec = run(Command::new(&objdump).args(["-s", "--section=.vector_table"]).arg(elf))?;
        let syms = run(Command::new(&nm).args(["-n", "-S", "--defined-only", "-C"]).arg(elf))?;
        let insns = parse_disassembly(&asm);
        let inline_names = inline_names(elf, insns.keys().copied())?;
        Ok(Program {
            insns,
            inline_names,
            symbols: parse_symbols(&syms),
            vectors: parse_vectors(&vec)?,
        })
    }

    #[cfg(test)]
    pub fn from_parts(insns: HashMap<u32, Insn>, symbols: Vec<Symbol>, vectors: Vec<u32>) -> Self {
        Program { insns, inline_names: HashMap::new(), symbols, vectors }
    }

    /// The function containing `addr`.
    pub fn symbol_at(&self, addr: u32) -> Option<&Symbol> {
        let i = self.symbols.partition_point(|s| s.addr <= addr).checked_sub(1)?;
        let s = &self.symbols[i];
        (addr < s.addr + s.size.max(2)).then_some(s)
    }

    pub fn symbols(&self) -> &[Symbol] {
        &self.symbols
    }

    /// The handler of interrupt `irq` (exception number 16 + irq).
    pub fn irq_handler(&self, irq: usize) -> Result<u32> {
        self.vectors.get(16 + irq).copied().filter(|&a| a != 0).context("no such vector")
    }
}

/// The inline chain of every address: each frame's function, demangled without its hash.
fn inline_names(elf: &Path, addrs: impl Iterator<Item = u32>) -> Result<HashMap<u32, Vec<String>>> {
    let loader = addr2line::Loader::new(elf)
        .map_err(|e| anyhow::anyhow!("reading the DWARF of {}: {e}", elf.display()))?;
    let mut out = HashMap::new();
    for a in addrs {
        let Ok(mut frames) = loader.find_frames(a as u64) else { continue };
        let mut names = Vec::new();
        while let Ok(Some(f)) = frames.next() {
            if let Some(name) = f.function.as_ref().and_then(|n| n.demangle().ok()) {
                names.push(strip_hash(&name).to_string());
            }
        }
        out.insert(a, names);
    }
    Ok(out)
}

fn run(cmd: &mut Command) -> Result<String> {
    let out = cmd.output().with_context(|| format!("could not run {cmd:?}"))?;
    if !out.status.success() {
        bail!("{cmd:?} failed: {}", String::from_utf8_lossy(&out.stderr));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

fn parse_vectors(dump: &str) -> Result<Vec<u32>> {
    let mut bytes = Vec::new();
    for line in dump.lines() {
        let mut parts = line.split_whitespace();
        let Some(addr) = parts.next() else { continue };
        if u32::from_str_radix(addr, 16).is_err() || addr.len() < 6 {
            continue;
        }
        for word in parts.take(4) {
            if word.len() % 2 != 0 || word.chars().any(|c| !c.is_ascii_hexdigit()) {
                break;
            }
            for k in (0..word.len()).step_by(2) {
                bytes.push(u8::from_str_radix(&word[k..k + 2], 16)?);
            }
        }
    }
    if bytes.len() < 64 {
        bail!("the ELF has no .vector_table");
    }
    Ok(bytes.chunks_exact(4).map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]) & !1).collect())
}

fn parse_symbols(nm: &str) -> Vec<Symbol> {
    let mut out: Vec<Symbol> = nm
        .lines()
        .filter_map(|line| {
            let mut p = line.splitn(4, ' ');
            let addr = u32::from_str_radix(p.next()?, 16).ok()?;
            let size = u32::from_str_radix(p.next()?, 16).ok()?;
            let kind = p.next()?;
            let name = p.next()?;
            (matches!(kind, "T" | "t" | "W" | "w") && size != 0).then(|| Symbol {
                addr: addr & !1,
                size,
                name: strip_hash(name).to_string(),
            })
        })
        .collect();
    out.sort_by_key(|s| s.addr);
    out
}

/// `path::f::h0123456789abcdef` -> `path::f`.
fn strip_hash(name: &str) -> &str {
    match name.rfind("::h") {
        Some(i) if name.len() - i == 19 => &name[..i],
        _ => name,
    }
}

/// `llvm-objdump -d --no-show-raw-insn` text -> instructions by address; sizes from the next
/// address (Thumb-2: 2 or 4 bytes).
pub fn parse_disassembly(asm: &str) -> HashMap<u32, Insn> {
    let rows: Vec<(u32, &str, &str)> = asm
        .lines()
        .filter_map(|line| {
            let (addr, rest) = line.trim_start().split_once(':')?;
            let addr = u32::from_str_radix(addr, 16).ok()?;
            let rest = rest.trim();
            let rest = rest.split('@').next()?.trim();
            let (mn, ops) = rest.split_once(char::is_whitespace).unwrap_or((rest, ""));
            (!mn.is_empty() && !mn.starts_with('<')).then_some((addr, mn, ops.trim()))
        })
        .collect();
    let mut out = HashMap::with_capacity(rows.len());
    for (i, &(addr, mn, ops)) in rows.iter().enumerate() {
        let next = rows.get(i + 1).map(|r| r.0);
        let size = match next.map(|n| n.wrapping_sub(addr)) {
            Some(2) => 2,
            _ if mn.ends_with(".w") => 4,
            Some(4) => 4,
            _ => 2,
        };
        let mut insn = classify(mn, ops);
        insn.size = size;
        insn.in_flash = FLASH.contains(&addr);
        out.insert(addr, insn);
    }
    out
}

const CONDITIONS: [&str; 16] = [
    "eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le",
];

/// The mnemonic without `.w`/`.n` and without a condition suffix (`addcs` -> `add`), keeping
/// mnemonics that merely end in condition letters (`bls` is `b` + `ls`, `teq` stays `teq`).
fn base_mnemonic(mn: &str) -> &str {
    let m = mn.split('.').next().unwrap_or(mn);
    const KEEP: [&str; 12] = [
        "teq", "mls", "cmn", "bic", "bics", "vcmp", "vcmpe", "vmls", "smlal", "umlal", "cls",
        "vcls",
    ];
    if KEEP.contains(&m) || m.starts_with("it") {
        return m;
    }
    for c in CONDITIONS {
        if let Some(stem) = m.strip_suffix(c) {
            if !stem.is_empty() {
                return stem;
            }
        }
    }
    m
}

fn register_count(ops: &str) -> u32 {
    let Some(list) = ops.split('{').nth(1).and_then(|s| s.split('}').next()) else {
        return 1;
    };
    list.split(',')
        .map(str::trim)
        .filter(|r| !r.is_empty())
        .map(|r| match r.split_once('-') {
            Some((a, b)) => {
                let n = |s: &str| s.trim_start_matches(|c: char| c.is_alphabetic()).parse::<u32>();
                match (n(a), n(b)) {
                    (Ok(a), Ok(b)) if b >= a => b - a + 1,
                    _ => 1,
                }
            }
            None => 1,
        })
        .sum()
}

fn classify(mn: &str, ops: &str) -> Insn {
    let m = base_mnemonic(mn);
    let writes_pc = ops.starts_with("pc,") || ops == "pc";
    let list_has_pc = ops.contains("pc}") || ops.contains(", pc}") || ops.contains("{pc");
    let plain = |base: u32, mem: Mem| Insn {
        size: 2,
        flow: Flow::None,
        mem,
        base,
        taken: 0,
        fp: m.starts_with('v'),
        in_flash: true,
        always: false,
    };
    let jump = |base: u32, flow: Flow, mem: Mem| Insn {
        size: 2,
        flow,
        mem,
        base,
        taken: REFILL,
        fp: false,
        in_flash: true,
        always: !matches!(m, "cbz" | "cbnz") && m == mn.split('.').next().unwrap_or(mn),
    };
    match m {
        "bl" | "blx" => jump(1, Flow::Call, Mem::None),
        "bx" if ops == "lr" => jump(1, Flow::Return, Mem::None),
        "bx" => jump(1, Flow::Branch, Mem::None),
        "b" | "cbz" | "cbnz" => jump(1, Flow::Branch, Mem::None),
        "tbb" | "tbh" => jump(2, Flow::Branch, Mem::Other),
        "pop" if list_has_pc => jump(1 + register_count(ops), Flow::Return, Mem::Other),
        "ldm" | "ldmia" | "ldmfd" if list_has_pc => {
            let flow = if ops.starts_with("sp") { Flow::Return } else { Flow::Branch };
            jump(1 + register_count(ops), flow, Mem::Other)
        }
        _ if m.starts_with("ldr") && writes_pc => {
            let flow = if ops.contains("[sp]") || ops.contains("[sp],") {
                Flow::Return
            } else {
                Flow::Branch
            };
            jump(2, flow, Mem::Other)
        }
        "mov" | "add" if writes_pc => jump(1, Flow::Branch, Mem::None),
        "pop" | "push" | "ldm" | "ldmia" | "ldmfd" | "ldmdb" | "stm" | "stmia" | "stmea"
        | "stmdb" | "stmfd" | "vpush" | "vpop" | "vldmia" | "vstmia" | "vldmdb" | "vstmdb"
        | "vldm" | "vstm" => plain(1 + register_count(ops), Mem::Other),
        "ldrd" | "strd" | "ldrexd" | "strexd" => plain(3, Mem::Other),
        "vldr" | "vstr" => plain(2, Mem::Other),
        "mla" | "mls" => plain(2, Mem::None),
        "sdiv" | "udiv" => plain(12, Mem::None),
        "dmb" | "dsb" | "isb" => plain(3, Mem::None),
        _ if m.starts_with("ldr") || m.starts_with("lda") => plain(2, Mem::SingleLoad),
        _ if m.starts_with("str") || m.starts_with("stl") => plain(1, Mem::SingleStore),
        _ => plain(1, Mem::None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes_follow_the_trm() {
        let c = |mn, ops| classify(mn, ops);
        assert_eq!(c("adds", "r4, r4, r5").base, 1);
        assert_eq!(c("addcs", "r4, r4, r1").base, 1);
        assert_eq!(c("ldm", "r0, {r2, r3, r4, r5, r8, r9, r10, r12}").base, 9);
        assert_eq!(c("push.w", "{r4, r5, r6, r7, r8, r9, r10, r11, lr}").base, 10);
        assert_eq!(c("pop.w", "{r8, r9, r10, r11}").flow, Flow::None);
        let ret = c("pop", "{r4, r5, r6, r7, pc}");
        assert_eq!((ret.flow, ret.base, ret.taken), (Flow::Return, 6, REFILL));
        assert_eq!(c("bx", "lr").flow, Flow::Return);
        assert_eq!(c("bl", "0x8000000").flow, Flow::Call);
        assert_eq!(c("bls", "0x8000000").flow, Flow::Branch);
        assert_eq!(c("teq", "r0, r1").flow, Flow::None);
        assert_eq!(c("ldr", "r0, [r1, #4]").mem, Mem::SingleLoad);
        assert_eq!(c("ldrd", "r2, r3, [r0]").base, 3);
        assert_eq!(c("udiv", "r0, r1, r2").base, 12);
        assert_eq!(c("umull", "r0, r1, r2, r3").base, 1);
        assert!(c("vldr", "s0, [r0]").fp);
        assert!(!c("str", "r0, [r1]").fp);
    }

    #[test]
    fn loads_pipeline_behind_loads_and_stores() {
        let ldr = classify("ldr", "r0, [r1]");
        assert_eq!(ldr.cycles(false, false, false), 2);
        assert_eq!(ldr.cycles(false, true, false), 1);
        let b = Insn { in_flash: true, ..classify("b", "0x8000000") };
        assert_eq!(b.cycles(false, false, false), 1);
        assert_eq!(b.cycles(true, false, false), 1 + REFILL);
        assert_eq!(b.cycles(true, false, true), 1 + REFILL + FLASH_WAIT_STATES);
    }

    #[test]
    fn disassembly_rows_become_sized_instructions() {
        let asm = "080148f8 <TIM2>:\n 80148f8:      \tpush\t{r4, r5, r6, r7, lr}\n \
                   80148fa:      \tadd\tr7, sp, #0xc\n 80148fc:      \tpush.w\t{r8, r9, r10, r11}\n \
                   8014900:      \tbhi\t0x8014970 <TIM2+0x78>   @ imm = #0x2a\n \
                   8014902:      \tpop\t{r4, r5, r6, r7, pc}\n";
        let p = parse_disassembly(asm);
        assert_eq!(p[&0x080148f8].size, 2);
        assert_eq!(p[&0x080148fc].size, 4);
        assert_eq!(p[&0x08014900].flow, Flow::Branch);
        assert_eq!(p[&0x08014902].flow, Flow::Return);
    }
}
