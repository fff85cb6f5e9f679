//! Worst-case stack per entry point, from the per-function frame sizes that `rustc -Z
//! emit-stack-sizes` stores in `.stack_sizes` (kept in the firmware ELF by its linker script)
//! and the call graph read from `llvm-objdump -d` of the same ELF.
//!
//! Bound for an entry point `f`: `frame(f) + max over callees g of bound(g)`. Tail calls
//! (`b`/`b.w` to another function) are treated as calls, which over-estimates slightly.
//! The bound is only reported if every function reached has a known frame size, there is no
//! indirect call (`blx rN`) and no recursion; otherwise the reason is printed instead.
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

/// Direct callees per function, and functions with an indirect call, from `llvm-objdump -d`.
fn call_graph(objdump: &str) -> (BTreeMap<String, BTreeSet<String>>, BTreeSet<String>) {
    let mut calls: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut indirect = BTreeSet::new();
    let mut current: Option<String> = None;
    for line in objdump.lines() {
        // Function header: "000012a4 <name>:"
        if let Some(rest) = line.strip_suffix(">:") {
            if let Some(pos) = rest.find(" <") {
                let name = rest[pos + 2..].to_string();
                calls.entry(name.clone()).or_default();
                current = Some(name);
                continue;
            }
        }
        let Some(func) = current.as_ref() else { continue };
        // Instruction: "    12a4: f0 b5   push {r4, r5, r6, r7, lr}" (tab separated).
        let fields: Vec<&str> = line.split('\t').collect();
        let Some(mnemonic) = fields.iter().map(|f| f.trim()).find(|f| is_branch(f)) else { continue };
        let operands = line.rsplit('\t').next().unwrap_or("");
        if let (Some(s), Some(e)) = (operands.find('<'), operands.rfind('>')) {
            let target = &operands[s + 1..e];
            if !target.contains('+') && target != func {
                calls.entry(func.clone()).or_default().insert(target.to_string());
            }
        } else if mnemonic.starts_with("blx") || (mnemonic.starts_with("bx") && !operands.contains("lr")) {
            indirect.insert(func.clone());
        }
    }
    (calls, indirect)
}

fn is_branch(m: &str) -> bool {
    matches!(m, "bl" | "blx" | "b" | "b.w" | "bx") || m.starts_with("b.") && m.len() <= 4
}

/// Worst-case stack of `entry`, or the reason it cannot be bounded.
fn bound(
    f: &str,
    calls: &BTreeMap<String, BTreeSet<String>>,
    indirect: &BTreeSet<String>,
    sizes: &BTreeMap<u64, u64>,
    addr_of: &BTreeMap<String, u64>,
    path: &mut Vec<String>,
    memo: &mut BTreeMap<String, Result<u64, String>>,
) -> Result<u64, String> {
    if let Some(r) = memo.get(f) {
        return r.clone();
    }
    if path.iter().any(|p| p == f) {
        return Err(format!("recursion through {f}"));
    }
    let r = (|| {
        if indirect.contains(f) {
            return Err(format!("indirect call in {f}"));
        }
        let addr = addr_of.get(f).ok_or_else(|| format!("no symbol {f}"))?;
        let own = *sizes.get(addr).ok_or_else(|| format!("no stack size for {f}"))?;
        path.push(f.to_string());
        let mut deepest = 0u64;
        for g in calls.get(f).into_iter().flatten() {
            deepest = deepest.max(bound(g, calls, indirect, sizes, addr_of, path, memo)?);
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
    let (calls, indirect) = call_graph(&text);
    let mut memo = BTreeMap::new();
    for entry in args.get(2..).unwrap_or(&[]) {
        match bound(entry, &calls, &indirect, &sizes, &addr_of, &mut Vec::new(), &mut memo) {
            Ok(b) => println!("{entry}\t{b}"),
            Err(why) => println!("{entry}\tunbounded: {why}"),
        }
    }
    Ok(())
}
