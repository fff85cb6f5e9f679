//! Worst-case stack per entry point, from the per-function frame sizes that `rustc -Z
//! emit-stack-sizes` stores in `.stack_sizes` (kept in the firmware ELF by its linker script)
//! and the call graph read from `llvm-objdump -d` of the same ELF.
//!
//! Bound for an entry point `f`: `frame(f) + max over callees g of bound(g)`. Tail calls
//! (`b`/`b.w` to another function) are treated as calls, which over-estimates slightly.
//! Functions without a `.stack_sizes` entry (the precompiled `compiler_builtins` of the
//! sysroot: soft-float, 64-bit division, memcpy) get a frame read from their prologue in the
//! disassembly (`push`/`vpush` register lists and `sub sp, #N`); their number is reported.
//! The bound is only reported if there is no indirect call (`blx rN`) and no recursion;
//! otherwise the reason is printed instead.
use object::{Object, ObjectSection, ObjectSymbol};
use std::collections::{BTreeMap, BTreeSet};

/// Frame size per function start address, from `.stack_sizes` (32-bit address + ULEB128).
fn frame_sizes(data: &[u8]) -> Result<(BTreeMap<u64, u64>, BTreeMap<String, u64>), String> {
    let file = object::File::parse(data).map_err(|e| format!("not an ELF file: {e}"))?;
    let section = file
        .section_by_name(".stack_sizes")
        .ok_or("no .stack_sizes section (build with RUSTFLAGS=-Zemit-stack-sizes on nightly)")?;
    let bytes = section.data().map_err(|e| format!(".stack_sizes: {e}"))?;
    let mut sizes = BTreeMap::new();
    let mut i = 0usize;
    while i + 4 <= bytes.len() {
        let mut a = [0u8; 4];
        a.copy_from_slice(&bytes[i..i + 4]);
        let addr = u64::from(u32::from_le_bytes(a)) & !1;
        i += 4;
        let (mut value, mut shift) = (0u64, 0u32);
        loop {
            let Some(&b) = bytes.get(i) else { return Err(".stack_sizes: truncated ULEB128".into()) };
            i += 1;
            value |= u64::from(b & 0x7f) << shift;
            shift += 7;
            if b & 0x80 == 0 {
                break;
            }
        }
        sizes.insert(addr, value);
    }
    let mut addr_of = BTreeMap::new();
    for sym in file.symbols() {
        if let Ok(name) = sym.name() {
            if sym.kind() == object::SymbolKind::Text {
                addr_of.insert(name.to_string(), sym.address() & !1);
            }
        }
    }
    Ok((sizes, addr_of))
}

/// What the disassembly says about the functions.
#[derive(Default)]
struct Disassembly {
    /// Direct callees per function.
    calls: BTreeMap<String, BTreeSet<String>>,
    /// Functions with an indirect call.
    indirect: BTreeSet<String>,
    /// Frame size read from the prologue (push, vpush, sub sp), bytes.
    prologue_frame: BTreeMap<String, u64>,
}

/// Bytes pushed by `push {r4, r5, lr}` / `vpush {d8, d9}` / `sub sp, #N` (0 for other lines).
fn frame_bytes(mnemonic: &str, operands: &str) -> u64 {
    let regs = |ops: &str| -> u64 {
        let inner = ops.trim().trim_start_matches('{').trim_end_matches('}');
        inner
            .split(',')
            .map(|r| {
                let r = r.trim();
                // Ranges such as r4-r7 or d8-d15.
                match r.split_once('-') {
                    Some((a, b)) => {
                        let n = |x: &str| x.trim_start_matches(|c: char| c.is_ascii_alphabetic()).parse::<u64>().unwrap_or(0);
                        n(b).saturating_sub(n(a)) + 1
                    }
                    None if r.is_empty() => 0,
                    None => 1,
                }
            })
            .sum()
    };
    match mnemonic {
        "push" | "push.w" | "stmdb" => 4 * regs(operands.trim_start_matches("sp!,")),
        "vpush" => {
            let width = if operands.contains('d') { 8 } else { 4 };
            width * regs(operands)
        }
        "sub" | "sub.w" | "subw" if operands.trim_start().starts_with("sp, ") => operands
            .rsplit('#')
            .next()
            .and_then(|n| {
                let n = n.trim();
                n.strip_prefix("0x").map_or_else(|| n.parse().ok(), |h| u64::from_str_radix(h, 16).ok())
            })
            .unwrap_or(0),
        _ => 0,
    }
}

/// Direct callees per function, indirect calls and prologue frames, from `llvm-objdump -d`.
fn call_graph(objdump: &str) -> Disassembly {
    let mut d = Disassembly::default();
    // Function start addresses (ARM mapping symbols $t/$d/$a excluded).
    let mut starts: BTreeMap<u64, String> = BTreeMap::new();
    for line in objdump.lines() {
        if let Some(rest) = line.strip_suffix(">:") {
            if let Some(pos) = rest.find(" <") {
                let name = &rest[pos + 2..];
                if let (false, Ok(addr)) = (name.starts_with('$'), u64::from_str_radix(rest[..pos].trim(), 16)) {
                    starts.insert(addr, name.to_string());
                }
            }
        }
    }
    let (calls, indirect) = (&mut d.calls, &mut d.indirect);
    let mut current: Option<String> = None;
    let mut in_prologue = false;
    for line in objdump.lines() {
        // Function header: "000012a4 <name>:" (ARM mapping symbols $t/$d/$a are not functions).
        if let Some(rest) = line.strip_suffix(">:") {
            if let Some(pos) = rest.find(" <") {
                let name = rest[pos + 2..].to_string();
                if name.starts_with('$') {
                    continue;
                }
                calls.entry(name.clone()).or_default();
                d.prologue_frame.insert(name.clone(), 0);
                current = Some(name);
                in_prologue = true;
                continue;
            }
        }
        let Some(func) = current.as_ref() else { continue };
        let fields: Vec<&str> = line.split('\t').map(str::trim).filter(|f| !f.is_empty()).collect();
        if in_prologue && fields.len() >= 2 {
            // fields: address, mnemonic, operands (raw bytes are not printed: --no-show-raw-insn).
            let mnemonic = fields.get(1).copied().unwrap_or("");
            let operands = fields.get(2).copied().unwrap_or("");
            let bytes = frame_bytes(mnemonic, operands);
            if let Some(f) = d.prologue_frame.get_mut(func) {
                *f += bytes;
            }
            // The prologue ends at the first branch.
            if is_branch(mnemonic) || mnemonic.starts_with("cbz") || mnemonic.starts_with("cbnz") {
                in_prologue = false;
            }
        }
        // Instruction: "    12a4: f0 b5   push {r4, r5, r6, r7, lr}" (tab separated).
        let Some(mnemonic) = fields.get(1).copied().filter(|m| is_branch(m)) else { continue };
        let operands = fields.get(2).copied().unwrap_or("");
        if let Some(target) = operands.strip_prefix("0x").and_then(|h| u64::from_str_radix(h.split_whitespace().next().unwrap_or(""), 16).ok()) {
            // Resolve the target address to the function that contains it (symbol names in
            // the operand may be ARM mapping symbols such as `$t`).
            if let Some((_, callee)) = starts.range(..=target).next_back() {
                if callee != func {
                    calls.entry(func.clone()).or_default().insert(callee.clone());
                }
            }
        } else if mnemonic.starts_with("blx") || (mnemonic.starts_with("bx") && operands != "lr") {
            indirect.insert(func.clone());
        }
    }
    d
}

fn is_branch(m: &str) -> bool {
    const COND: [&str; 14] = ["eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt"];
    let m = m.trim_end_matches(".w").trim_end_matches(".n");
    matches!(m, "b" | "bl" | "blx" | "bx" | "bgt" | "ble" | "bal") || m.strip_prefix('b').is_some_and(|c| COND.contains(&c))
}

/// A function of `core::panicking` (mangled `..4core9panicking..`).
fn is_panic(name: &str) -> bool {
    name.contains("4core9panicking") || name.starts_with("rust_begin_unwind")
}

/// The last two path components of a Rust symbol without generic arguments, for messages.
fn short(name: &str) -> String {
    let mut full = format!("{:#}", rustc_demangle::demangle(name));
    // `<path::Type<..> as Trait>::method` or `<path::Type<..>>::method`: keep the type path.
    if full.starts_with('<') {
        let mut depth = 0usize;
        let close = full.char_indices().find_map(|(i, c)| {
            match c {
                '<' => depth += 1,
                '>' => {
                    depth = depth.saturating_sub(1);
                    if depth == 0 {
                        return Some(i);
                    }
                }
                _ => {}
            }
            None
        });
        if let Some(i) = close {
            let inner = &full[1..i];
            let ty = inner.split(" as ").next().unwrap_or(inner);
            full = format!("{ty}{}", &full[i + 1..]);
        }
    }
    let mut plain = String::new();
    let mut depth = 0usize;
    for c in full.chars() {
        match c {
            '<' => depth += 1,
            '>' => depth = depth.saturating_sub(1),
            _ if depth == 0 => plain.push(c),
            _ => {}
        }
    }
    let parts: Vec<&str> = plain.split("::").filter(|p| !p.is_empty()).collect();
    parts.iter().rev().take(2).rev().copied().collect::<Vec<_>>().join("::")
}

/// Worst-case stack of `entry`, or the reason it cannot be bounded.
fn bound(
    f: &str,
    dis: &Disassembly,
    sizes: &BTreeMap<u64, u64>,
    addr_of: &BTreeMap<String, u64>,
    path: &mut Vec<String>,
    memo: &mut BTreeMap<String, Result<u64, String>>,
    from_prologue: &mut BTreeSet<String>,
    panics: &mut BTreeSet<String>,
) -> Result<u64, String> {
    if let Some(r) = memo.get(f) {
        return r.clone();
    }
    if path.iter().any(|p| p == f) {
        return Err(format!("recursion through {f}"));
    }
    let r = (|| {
        if dis.indirect.contains(f) {
            return Err(format!("indirect call in {f}"));
        }
        let own = match addr_of.get(f).and_then(|a| sizes.get(a)) {
            Some(s) => *s,
            None => {
                from_prologue.insert(f.to_string());
                *dis.prologue_frame.get(f).ok_or_else(|| format!("no stack size and no code for {f}"))?
            }
        };
        path.push(f.to_string());
        let mut deepest = 0u64;
        for g in dis.calls.get(f).into_iter().flatten() {
            // `core::panicking::*` never returns: a panic path is reported, not bounded.
            if is_panic(g) {
                panics.insert(format!("{} -> {}", short(f), short(g)));
                continue;
            }
            deepest = deepest.max(bound(g, dis, sizes, addr_of, path, memo, from_prologue, panics)?);
        }
        path.pop();
        Ok(own + deepest)
    })();
    memo.insert(f.to_string(), r.clone());
    r
}

pub fn main(args: &[String]) -> Result<(), String> {
    let (Some(elf), Some(dump)) = (args.first(), args.get(1)) else {
        return Err("usage: stack FIRMWARE.elf OBJDUMP.txt SYMBOL...".into());
    };
    let data = std::fs::read(elf).map_err(|e| format!("{elf}: {e}"))?;
    let text = std::fs::read_to_string(dump).map_err(|e| format!("{dump}: {e}"))?;
    let (sizes, addr_of) = frame_sizes(&data).map_err(|e| format!("{elf}: {e}"))?;
    let dis = call_graph(&text);
    let mut from_prologue = BTreeSet::new();
    for entry in args.get(2..).unwrap_or(&[]) {
        // Panic sites reachable from this entry point (a fresh memo per entry point, so that
        // every site is seen).
        let mut panics = BTreeSet::new();
        let r = bound(entry, &dis, &sizes, &addr_of, &mut Vec::new(), &mut BTreeMap::new(), &mut from_prologue, &mut panics);
        let note = if panics.is_empty() {
            String::new()
        } else {
            format!("\tpanic path reachable: {}", panics.into_iter().collect::<Vec<_>>().join("; "))
        };
        match r {
            Ok(b) => println!("{entry}\t{b}{note}"),
            Err(why) => println!("{entry}\tunbounded: {why}{note}"),
        }
    }
    if !from_prologue.is_empty() {
        let names: Vec<&str> = from_prologue.iter().map(String::as_str).collect();
        println!("# frames read from the prologue (no .stack_sizes entry): {}", names.join(" "));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prologue_frames() {
        assert_eq!(frame_bytes("push", "{r4, r5, r6, r7, lr}"), 20);
        assert_eq!(frame_bytes("push.w", "{r4, r5, r6, r7, r8, r9, r10, r11, lr}"), 36);
        assert_eq!(frame_bytes("vpush", "{d8, d9, d10}"), 24);
        assert_eq!(frame_bytes("vpush", "{d8-d15}"), 64);
        assert_eq!(frame_bytes("sub", "sp, #88"), 88);
        assert_eq!(frame_bytes("sub.w", "sp, sp, #1024"), 1024);
        assert_eq!(frame_bytes("sub", "r0, #8"), 0);
        assert_eq!(frame_bytes("mov", "r7, sp"), 0);
    }

    #[test]
    fn call_graph_and_bound() {
        let dump = "00001000 <a>:\n    1000:      \tpush\t{r4, lr}\n    1002:      \tbl\t0x2000 <b>\n    1006:      \tbl\t0x1000 <a+0x8>\n\n00002000 <b>:\n    2000:      \tsub\tsp, #16\n    2002:      \tbx\tlr\n\n00003000 <c>:\n    3000:      \tblx\tr3\n";
        let d = call_graph(dump);
        assert_eq!(d.calls["a"].iter().collect::<Vec<_>>(), vec!["b"]);
        assert!(d.indirect.contains("c"));
        assert_eq!(d.prologue_frame["a"], 8);
        assert_eq!(d.prologue_frame["b"], 16);
        let sizes: BTreeMap<u64, u64> = [(0x1000, 24)].into_iter().collect();
        let addr_of: BTreeMap<String, u64> = [("a".to_string(), 0x1000), ("b".to_string(), 0x2000)].into_iter().collect();
        let mut fp = BTreeSet::new();
        let mut panics = BTreeSet::new();
        let b = bound("a", &d, &sizes, &addr_of, &mut Vec::new(), &mut BTreeMap::new(), &mut fp, &mut panics);
        assert_eq!(b, Ok(24 + 16));
        assert!(fp.contains("b"));
        assert!(panics.is_empty());
        assert!(bound("c", &d, &sizes, &addr_of, &mut Vec::new(), &mut BTreeMap::new(), &mut fp, &mut panics).is_err());
        assert_eq!(short("_RNvNtCs35XhZlOlJ4b_4core9panicking18panic_bounds_check"), "panicking::panic_bounds_check");
        assert_eq!(short("_ZN13massid_kernel2lu15Lu$LT$S$C$_$GT$6factor17h5b5a64df40670068E"), "Lu::factor");
    }
}
