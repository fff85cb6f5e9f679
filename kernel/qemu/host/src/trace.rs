//! Instruction counts from a QEMU exec trace (`-singlestep -d exec,nochain`: one `Trace` line
//! per executed instruction, the guest PC second in the bracket).
//!
//! The marker symbols (`massid_mark_begin`, `massid_mark_end`, `massid_mark_kind_*`) are read
//! from the firmware ELF. A count runs from the first instruction of `begin` to the first
//! instruction of `end` and is filed under the kind marker executed next; the count of the
//! empty calibration bracket (the markers' own instructions) is subtracted from every other.
use object::{Object, ObjectSymbol};
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Write};

/// Marker addresses, and the function symbols for the per-function profile.
#[derive(Debug, Default)]
pub struct Markers {
    begin: u64,
    end: u64,
    kinds: BTreeMap<u64, String>,
    flavours: BTreeMap<u64, String>,
    /// Function start address -> (end address, index into `names`).
    functions: BTreeMap<u64, (u64, usize)>,
    names: Vec<String>,
}

impl Markers {
    /// Index of the function containing `pc` (`usize::MAX` if none).
    fn function_of(&self, pc: u64) -> usize {
        match self.functions.range(..=pc).next_back() {
            Some((_, &(end, idx))) if pc < end => idx,
            _ => usize::MAX,
        }
    }
}

impl Markers {
    /// Reads the marker symbols from an ELF image.
    pub fn from_elf(data: &[u8]) -> Result<Self, String> {
        let file = object::File::parse(data).map_err(|e| format!("not an ELF file: {e}"))?;
        let mut m = Markers::default();
        for sym in file.symbols() {
            let Ok(name) = sym.name() else { continue };
            // Thumb function symbols carry the mode in bit 0.
            let addr = sym.address() & !1;
            if sym.kind() == object::SymbolKind::Text && sym.size() > 0 {
                m.functions.insert(addr, (addr + sym.size(), m.names.len()));
                m.names.push(format!("{:#}", rustc_demangle::demangle(name)));
            }
            match name {
                "massid_mark_begin" => m.begin = addr,
                "massid_mark_end" => m.end = addr,
                _ => {
                    if let Some(kind) = name.strip_prefix("massid_mark_kind_") {
                        m.kinds.insert(addr, kind.to_string());
                    } else if let Some(flavour) = name.strip_prefix("massid_mark_flavour_") {
                        m.flavours.insert(addr, flavour.to_string());
                    }
                }
            }
        }
        if m.begin == 0 || m.end == 0 || m.kinds.is_empty() {
            return Err("marker symbols massid_mark_begin/_end/_kind_* not found".into());
        }
        Ok(m)
    }
}

/// Instructions per function index, per kind.
pub type Profile = BTreeMap<String, BTreeMap<usize, u64>>;

/// Per-kind raw counts (marker overhead included), in call order. Kinds are prefixed by the
/// flavour marker last executed (`fixed/kf_rls`), except the calibration bracket.
#[cfg(test)]
pub fn count_lines<R: BufRead>(markers: &Markers, input: R) -> Result<BTreeMap<String, Vec<u64>>, String> {
    count_and_profile(markers, input).map(|(c, _)| c)
}

/// [`count_lines`] plus, per kind, the instructions executed in each function.
#[cfg(test)]
pub fn count_and_profile<R: BufRead>(markers: &Markers, input: R) -> Result<(BTreeMap<String, Vec<u64>>, Profile), String> {
    count_and_profile_pcs(markers, input, None)
}

/// Instructions per guest PC, per kind (the finer profile: map the PCs to source lines with
/// `llvm-addr2line -i`).
pub type PcProfile = BTreeMap<String, BTreeMap<u64, u64>>;

/// [`count_and_profile`]; with `pcs`, also the instructions at each PC per kind into it.
pub fn count_and_profile_pcs<R: BufRead>(
    markers: &Markers,
    input: R,
    mut pcs: Option<&mut PcProfile>,
) -> Result<(BTreeMap<String, Vec<u64>>, Profile), String> {
    let mut pc_window: BTreeMap<u64, u64> = BTreeMap::new();
    let mut pending_pcs: BTreeMap<u64, u64> = BTreeMap::new();
    let mut per_kind: BTreeMap<String, Vec<u64>> = BTreeMap::new();
    let mut profile: Profile = BTreeMap::new();
    let mut window: BTreeMap<usize, u64> = BTreeMap::new();
    let mut pending_window: BTreeMap<usize, u64> = BTreeMap::new();
    let mut counting = false;
    let mut n = 0u64;
    let mut pending: Option<u64> = None;
    let mut flavour = String::new();
    for line in input.split(b'\n') {
        let line = line.map_err(|e| format!("reading the trace: {e}"))?;
        let Some(pc) = trace_pc(&line) else { continue };
        if pc == markers.begin {
            counting = true;
            n = 0;
            window.clear();
            pc_window.clear();
        } else if pc == markers.end && counting {
            counting = false;
            pending = Some(n);
            pending_window = std::mem::take(&mut window);
            pending_pcs = std::mem::take(&mut pc_window);
        } else if let Some(kind) = markers.kinds.get(&pc) {
            if let Some(c) = pending.take() {
                let key = if kind == "calibration" || flavour.is_empty() { kind.clone() } else { format!("{flavour}/{kind}") };
                let prof = profile.entry(key.clone()).or_default();
                for (f, k) in std::mem::take(&mut pending_window) {
                    *prof.entry(f).or_default() += k;
                }
                if let Some(pcs) = pcs.as_deref_mut() {
                    let at = pcs.entry(key.clone()).or_default();
                    for (p, k) in std::mem::take(&mut pending_pcs) {
                        *at.entry(p).or_default() += k;
                    }
                }
                per_kind.entry(key).or_default().push(c);
            }
        } else if let Some(f) = markers.flavours.get(&pc) {
            flavour.clone_from(f);
        }
        if counting {
            n += 1;
            *window.entry(markers.function_of(pc)).or_default() += 1;
            if pcs.is_some() {
                *pc_window.entry(pc).or_default() += 1;
            }
        }
    }
    Ok((per_kind, profile))
}

/// The `top` functions per kind by share of the kind's instructions, as TSV lines
/// `kind share% instructions function`.
pub fn format_profile(markers: &Markers, profile: &Profile, top: usize) -> String {
    let mut out = String::from("kind\tshare\tinstructions\tfunction\n");
    for (kind, funcs) in profile {
        let total: u64 = funcs.values().sum();
        let mut v: Vec<(&usize, &u64)> = funcs.iter().collect();
        v.sort_by(|a, b| b.1.cmp(a.1));
        for (f, k) in v.into_iter().take(top) {
            let name = markers.names.get(*f).map_or("?", String::as_str);
            let share = if total > 0 { 100.0 * *k as f64 / total as f64 } else { 0.0 };
            out.push_str(&format!("{kind}\t{share:.1}\t{k}\t{name}\n"));
        }
    }
    out
}

/// The guest PC of a `Trace 0: 0xHOST [cs_base/PC/flags/cflags] symbol` line.
fn trace_pc(line: &[u8]) -> Option<u64> {
    if !line.starts_with(b"Trace ") {
        return None;
    }
    let open = line.iter().position(|&b| b == b'[')?;
    let rest = line.get(open + 1..)?;
    let first = rest.iter().position(|&b| b == b'/')?;
    let rest = rest.get(first + 1..)?;
    let second = rest.iter().position(|&b| b == b'/')?;
    let hex = std::str::from_utf8(rest.get(..second)?).ok()?;
    u64::from_str_radix(hex, 16).ok()
}

/// Summary per kind: calls, min, mean, max (calibration subtracted).
pub fn summarise(per_kind: &BTreeMap<String, Vec<u64>>) -> Result<Vec<(String, usize, u64, u64, u64)>, String> {
    let calib = per_kind
        .get("calibration")
        .and_then(|v| v.first().copied())
        .ok_or("no calibration bracket in the trace (was it recorded with -singlestep -d exec,nochain?)")?;
    let mut rows = Vec::new();
    for (kind, counts) in per_kind {
        if kind == "calibration" || counts.is_empty() {
            continue;
        }
        let net: Vec<u64> = counts.iter().map(|c| c.saturating_sub(calib)).collect();
        let min = net.iter().copied().min().unwrap_or(0);
        let max = net.iter().copied().max().unwrap_or(0);
        let mean = net.iter().sum::<u64>() / net.len() as u64;
        rows.push((kind.clone(), net.len(), min, mean, max));
    }
    rows.push(("calibration".to_string(), 1, calib, calib, calib));
    Ok(rows)
}

pub fn main(args: &[String]) -> Result<(), String> {
    let Some(elf) = args.first() else {
        return Err("usage: count FIRMWARE.elf [PROFILE.tsv [PCS.tsv]] < TRACE".into());
    };
    let data = std::fs::read(elf).map_err(|e| format!("{elf}: {e}"))?;
    let markers = Markers::from_elf(&data).map_err(|e| format!("{elf}: {e}"))?;
    let stdin = std::io::stdin();
    let mut pcs = args.get(2).map(|_| PcProfile::new());
    let (per_kind, profile) =
        count_and_profile_pcs(&markers, BufReader::with_capacity(1 << 20, stdin.lock()), pcs.as_mut())?;
    if let Some(path) = args.get(1) {
        std::fs::write(path, format_profile(&markers, &profile, 12)).map_err(|e| format!("{path}: {e}"))?;
    }
    if let (Some(path), Some(pcs)) = (args.get(2), pcs) {
        let mut text = String::from("kind\tpc\tinstructions\n");
        for (kind, at) in pcs {
            for (pc, k) in at {
                text.push_str(&format!("{kind}\t{pc:#x}\t{k}\n"));
            }
        }
        std::fs::write(path, text).map_err(|e| format!("{path}: {e}"))?;
    }
    if let Ok(path) = std::env::var("MASSID_COUNT_CALLS") {
        let mut text = String::new();
        for (kind, counts) in &per_kind {
            for (i, c) in counts.iter().enumerate() {
                text.push_str(&format!("{kind}\t{i}\t{c}\n"));
            }
        }
        std::fs::write(&path, text).map_err(|e| format!("{path}: {e}"))?;
    }
    let rows = summarise(&per_kind)?;
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "kind\tcalls\tmin\tmean\tmax");
    for (kind, calls, min, mean, max) in rows {
        let _ = writeln!(out, "{kind}\t{calls}\t{min}\t{mean}\t{max}");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_guest_pc() {
        let l = b"Trace 0: 0x7f6fa0000240 [00800408/0001336e/00000110/ff000201] __pre_init";
        assert_eq!(trace_pc(l), Some(0x1336e));
        assert_eq!(trace_pc(b"Linking TBs 0x1 [00000000] index 0"), None);
    }

    #[test]
    fn counts_between_markers_and_files_under_the_next_kind() {
        let mut m = Markers { begin: 0x100, end: 0x200, ..Default::default() };
        m.kinds.insert(0x300, "calibration".into());
        m.kinds.insert(0x310, "idle".into());
        m.flavours.insert(0x320, "fixed".into());
        let line = |pc: u64| format!("Trace 0: 0x7f00 [00000000/{pc:08x}/00000110/ff000201] x\n");
        let mut t = String::new();
        // calibration: begin (2 insns) then end.
        for pc in [0x100, 0x102, 0x200, 0x202, 0x300] {
            t += &line(pc);
        }
        // a call: begin (2) + 5 body insns, then end, then the kind marker.
        for pc in [0x320, 0x100, 0x102, 0x400, 0x402, 0x404, 0x406, 0x408, 0x200, 0x310] {
            t += &line(pc);
        }
        let per = count_lines(&m, t.as_bytes()).unwrap();
        assert_eq!(per["calibration"], vec![2]);
        assert_eq!(per["fixed/idle"], vec![7]);
        let rows = summarise(&per).unwrap();
        assert_eq!(rows[0], ("fixed/idle".to_string(), 1, 5, 5, 5));
    }
}
