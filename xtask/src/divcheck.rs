//! Proves the tick interrupt never calls a software divide: disassembles the firmware, builds the
//! static call graph from the `TIM2` handler over direct branches (`bl`, `b`, `b.w`, conditional
//! branches, `cbz`/`cbnz` to other symbols) and fails if a reachable symbol is a divide helper.
//! Indirect calls (`blx rN`, function pointers) are not followed; the tick path has none. The
//! panic handler is reached (a bounds check that cannot fail still has its panic branch) but not
//! entered: it is the no-return fault path, which latches the outputs off and resets, so what it
//! costs is not tick time. Its own formatting may divide (with little else of core::fmt left in
//! the image, LTO turns its indirect formatter calls into direct ones).

use anyhow::{bail, Context, Result};
use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::path::Path;
use std::process::Command;

pub const ROOT: &str = "TIM2";
/// The panic handler's symbol, as the demangled disassembly names it (see the module docs).
const PANIC_HANDLER: &str = "rust_begin_unwind";

pub fn check_elf(elf: &Path) -> Result<()> {
    let root = crate::root();
    let objdump = crate::setup::llvm_tool(&root, "llvm-objdump")?;
    let out = Command::new(&objdump)
        .args(["-d", "--demangle", "--no-show-raw-insn"])
        .arg(elf)
        .output()
        .with_context(|| format!("could not run {}", objdump.display()))?;
    if !out.status.success() {
        bail!("llvm-objdump failed: {}", String::from_utf8_lossy(&out.stderr));
    }
    let asm = String::from_utf8_lossy(&out.stdout);
    let graph = call_graph(&asm);
    let reach = reachable(&graph, ROOT)?;
    let divs: Vec<&String> = reach.keys().filter(|s| is_soft_divide(s)).collect();
    if !divs.is_empty() {
        let mut msg = format!("software divide reachable from {ROOT}:");
        for d in divs {
            msg.push_str(&format!("\n  {}", path_to(&reach, d).join(" -> ")));
        }
        bail!(msg);
    }
    let elsewhere: Vec<&String> = graph.keys().filter(|s| is_soft_divide(s)).collect();
    println!(
        "{} functions reachable from {ROOT}, none a software divide (the ELF's divide helpers, \
         {elsewhere:?}, serve other tasks only):",
        reach.len()
    );
    for s in reach.keys() {
        println!("  {s}");
    }
    Ok(())
}

/// Compiler-rt / compiler-builtins helpers that divide in software.
pub fn is_soft_divide(sym: &str) -> bool {
    const NAMES: [&str; 16] = [
        "__udivmoddi4",
        "__divmoddi4",
        "__udivdi3",
        "__divdi3",
        "__umoddi3",
        "__moddi3",
        "__udivsi3",
        "__divsi3",
        "__umodsi3",
        "__modsi3",
        "__udivmodsi4",
        "__divmodsi4",
        "__udivti3",
        "__divti3",
        "__umodti3",
        "__udivmodti4",
    ];
    (sym.contains("__aeabi_") && sym.contains("div"))
        || NAMES.iter().any(|n| sym.contains(n))
        || sym.contains("specialized_div_rem")
}

/// Function -> directly branched-to functions, from `llvm-objdump -d` text.
pub fn call_graph(asm: &str) -> BTreeMap<String, BTreeSet<String>> {
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut current: Option<String> = None;
    for line in asm.lines() {
        // Function header: `08000400 <TIM2>:`
        if let Some(name) = header(line) {
            graph.entry(name.clone()).or_default();
            current = Some(name);
            continue;
        }
        let Some(func) = &current else { continue };
        // Instruction: ` 8000404:      bl      0x8000520 <foo> @ imm = #0x118`
        let Some((_, insn)) = line.split_once(':') else {
            continue;
        };
        let mut words = insn.split_whitespace();
        let Some(mnemonic) = words.next() else {
            continue;
        };
        if !is_branch(mnemonic) {
            continue;
        }
        let Some(target) = branch_target(insn) else {
            continue;
        };
        if target != *func {
            graph.entry(func.clone()).or_default().insert(target);
        }
    }
    graph
}

fn header(line: &str) -> Option<String> {
    let line = line.trim_end();
    let (addr, rest) = line.split_once(' ')?;
    if addr.is_empty() || !addr.chars().all(|c| c.is_ascii_hexdigit()) {
        return None;
    }
    let name = rest.strip_prefix('<')?.strip_suffix(">:")?;
    Some(name.to_string())
}

fn is_branch(m: &str) -> bool {
    const CONDS: [&str; 17] = [
        "", "eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt",
        "gt", "le",
    ];
    let m = m.trim_end_matches(".w").trim_end_matches(".n");
    if matches!(m, "cbz" | "cbnz" | "bl" | "blx") {
        return true;
    }
    m.strip_prefix('b').is_some_and(|cond| CONDS.contains(&cond))
}

/// `<sym>` or `<sym+0x12>` in the operands -> `sym`.
fn branch_target(insn: &str) -> Option<String> {
    let start = insn.find('<')? + 1;
    let end = start + insn[start..].rfind('>')?;
    let sym = &insn[start..end];
    let sym = match sym.rfind("+0x") {
        Some(i) => &sym[..i],
        None => sym,
    };
    Some(sym.to_string())
}

/// Every function reachable from `root`, each with the function it was reached from.
pub fn reachable(
    graph: &BTreeMap<String, BTreeSet<String>>,
    root: &str,
) -> Result<BTreeMap<String, Option<String>>> {
    if !graph.contains_key(root) {
        bail!("no function `{root}` in the disassembly");
    }
    let mut seen = BTreeMap::from([(root.to_string(), None)]);
    let mut todo = VecDeque::from([root.to_string()]);
    while let Some(f) = todo.pop_front() {
        if f.ends_with(PANIC_HANDLER) {
            continue;
        }
        for callee in graph.get(&f).into_iter().flatten() {
            if !seen.contains_key(callee) {
                seen.insert(callee.clone(), Some(f.clone()));
                todo.push_back(callee.clone());
            }
        }
    }
    Ok(seen)
}

fn path_to(reach: &BTreeMap<String, Option<String>>, sym: &str) -> Vec<String> {
    let mut path = vec![sym.to_string()];
    let mut cur = sym.to_string();
    while let Some(Some(parent)) = reach.get(&cur) {
        path.push(parent.clone());
        cur = parent.clone();
    }
    path.reverse();
    path
}

#[cfg(test)]
mod tests {
    use super::*;

    const ASM: &str = "
firmware:	file format elf32-littlearm

Disassembly of section .text:

08000400 <TIM2>:
 8000400:      	push	{r7, lr}
 8000402:      	bl	0x8000500 <motion::dda::Dda::tick>
 8000406:      	cmp	r0, #0
 8000408:      	beq	0x8000410 <TIM2+0x10>
 800040a:      	bic	r0, r0, #1
 800040c:      	b.w	0x8000600 <record_rises>
 8000410:      	pop	{r7, pc}

08000500 <motion::dda::Dda::tick>:
 8000500:      	cbz	r0, 0x8000508 <motion::dda::Dda::tick+0x8>
 8000502:      	bne.w	0x8000700 <load_next>
 8000506:      	blx	r3
 8000508:      	bx	lr

08000600 <record_rises>:
 8000600:      	bx	lr

08000700 <load_next>:
 8000700:      	bx	lr

08000800 <report>:
 8000800:      	bl	0x8000900 <__aeabi_uldivmod>

08000900 <__aeabi_uldivmod>:
 8000900:      	b.w	0x8000a00 <__udivmoddi4>

08000a00 <__udivmoddi4>:
 8000a00:      	bx	lr
";

    #[test]
    fn walks_direct_branches_only() {
        let g = call_graph(ASM);
        let r = reachable(&g, "TIM2").unwrap();
        let names: Vec<&str> = r.keys().map(String::as_str).collect();
        assert_eq!(names, ["TIM2", "load_next", "motion::dda::Dda::tick", "record_rises"]);
        assert!(!r.keys().any(|s| is_soft_divide(s)));
        assert_eq!(path_to(&r, "load_next"), ["TIM2", "motion::dda::Dda::tick", "load_next"]);
    }

    #[test]
    fn finds_a_divide_behind_a_tail_call() {
        // Make the tick path reach `report`, which divides.
        let asm = ASM.replace("0x8000600 <record_rises>", "0x8000800 <report>");
        let g = call_graph(&asm);
        let r = reachable(&g, "TIM2").unwrap();
        let divs: Vec<&String> = r.keys().filter(|s| is_soft_divide(s)).collect();
        assert_eq!(divs, ["__aeabi_uldivmod", "__udivmoddi4"]);
        assert_eq!(
            path_to(&r, "__udivmoddi4"),
            ["TIM2", "report", "__aeabi_uldivmod", "__udivmoddi4"]
        );
    }

    #[test]
    fn the_panic_handler_is_reached_but_not_entered() {
        // The tick's path reaches the panic handler, whose formatting divides.
        let asm = ASM.replace("0x8000600 <record_rises>", "0x8000b00 <__rustc::rust_begin_unwind>")
            + "\n08000b00 <__rustc::rust_begin_unwind>:\n 8000b00:      \tbl\t0x8000800 <report>\n";
        let r = reachable(&call_graph(&asm), "TIM2").unwrap();
        assert!(r.contains_key("__rustc::rust_begin_unwind"));
        assert!(!r.keys().any(|s| is_soft_divide(s)), "{r:?}");
        // The same divide reached another way is still found.
        let asm = asm.replace("0x8000700 <load_next>", "0x8000800 <report>");
        let r = reachable(&call_graph(&asm), "TIM2").unwrap();
        assert!(r.keys().any(|s| is_soft_divide(s)));
    }

    #[test]
    fn classifies_mnemonics_and_names() {
        for m in ["b", "bl", "b.w", "beq", "bne.w", "cbz", "cbnz", "blx"] {
            assert!(is_branch(m), "{m}");
        }
        for m in ["bic", "bics", "bfi", "bkpt", "bx", "mov"] {
            assert!(!is_branch(m), "{m}");
        }
        for s in ["__aeabi_uidiv", "__aeabi_ldivmod", "__divdi3", "__udivmoddi4"] {
            assert!(is_soft_divide(s), "{s}");
        }
        assert!(!is_soft_divide("motion::dda::Dda::tick"));
        assert!(reachable(&call_graph(ASM), "NOPE").is_err());
    }
}
