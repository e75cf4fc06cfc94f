//! Panic and HardFault handlers shared by the firmware binaries: record where it happened in RAM
//! that survives a reset, report over defmt, then end the run through the board (QEMU exits
//! non-zero; a real board latches its outputs safe and parks until its watchdog resets it). The
//! next boot finds the record ([`take_recorded`]), latches `Panicked` and reports the site in
//! `HelloInfo`, so `motionctl status` names it.

use core::mem::MaybeUninit;
use core::ptr::{addr_of, addr_of_mut};
use motion::protocol::{FixedStr, PanicSite, PANIC_FILE_LEN};

/// Marks a complete record (RAM holds noise after power-up).
const RECORD_MAGIC: u32 = 0x9A1C_5173;
/// `file` of a HardFault's record; its `line` is the faulting PC.
const HARD_FAULT_FILE: &str = "HardFault (line = PC)";

#[derive(Clone, Copy)]
#[repr(C)]
struct Record {
    magic: u32,
    line: u32,
    column: u32,
    file_len: u32,
    file: [u8; PANIC_FILE_LEN],
}

/// Not zeroed by the runtime at start-up (`.uninit` is NOLOAD in cortex-m-rt's link.x).
#[link_section = ".uninit.PANIC_SITE"]
static mut RECORD: MaybeUninit<Record> = MaybeUninit::uninit();

fn record(file: &str, line: u32, column: u32) {
    let tail = FixedStr::<PANIC_FILE_LEN>::tail(file);
    let mut bytes = [0u8; PANIC_FILE_LEN];
    bytes[..tail.len()].copy_from_slice(tail.as_bytes());
    let r = Record { magic: RECORD_MAGIC, line, column, file_len: tail.len() as u32, file: bytes };
    // SAFETY: interrupts are off and nothing else runs: the only access to RECORD now.
    unsafe { addr_of_mut!(RECORD).write_volatile(MaybeUninit::new(r)) };
}

/// The site recorded before the last reset, if a complete one is there; clears it. Call once
/// at boot, before interrupts run.
pub fn take_recorded() -> Option<PanicSite> {
    // SAFETY: read as raw bytes (any bit pattern is a valid Record) at boot, before anything
    // else can touch RECORD.
    let r = unsafe { addr_of!(RECORD).read_volatile().assume_init() };
    // SAFETY: as above; `magic` is the first field of the repr(C) record.
    unsafe { addr_of_mut!(RECORD).cast::<u32>().write_volatile(0) };
    if r.magic != RECORD_MAGIC || r.file_len as usize > PANIC_FILE_LEN {
        return None;
    }
    let file = core::str::from_utf8(&r.file[..r.file_len as usize]).ok()?;
    Some(PanicSite { file: FixedStr::truncated(file), line: r.line, column: r.column })
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    let (file, line, column) = match info.location() {
        Some(l) => (l.file(), l.line(), l.column()),
        None => ("(unknown)", 0, 0),
    };
    record(file, line, column);
    // The site and a constant message without core::fmt: formatting the PanicInfo would link
    // the whole formatting machinery (and every panic's argument formatting) into the image.
    // A message with arguments (an index out of bounds, say) is named by its site.
    let message = info.message().as_str().unwrap_or("(a formatted message; see the site)");
    defmt::error!("panicked at {=str}:{=u32}:{=u32}: {=str}", file, line, column, message);
    crate::board::exit(false)
}

#[cortex_m_rt::exception]
unsafe fn HardFault(ef: &cortex_m_rt::ExceptionFrame) -> ! {
    record(HARD_FAULT_FILE, ef.pc(), 0);
    defmt::error!(
        "HardFault: pc={=u32:#010x} lr={=u32:#010x} xpsr={=u32:#010x}",
        ef.pc(),
        ef.lr(),
        ef.xpsr()
    );
    crate::board::exit(false)
}
