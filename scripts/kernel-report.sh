#!/usr/bin/env bash
# Prints the kernel's embedded report as Markdown (also written to out/kernel/report.md):
#  - code size per target: .text of the kernel's objects in the release C-ABI static library
#    (crate massid-kernel-capi: both instantiations, pipeline + mixer, before link-time GC;
#    core/compiler_builtins excluded), and the linked QEMU firmware images;
#  - state size in bytes (size_of the pipeline and mixer, fixed and f32, 32-bit targets);
#  - worst-case stack per C-ABI entry point on Cortex-M0 and M4F (nightly -Zemit-stack-sizes
#    + call graph from llvm-objdump; massid-qemu-host stack);
#  - instructions per call on the emulated Cortex-M0 and M4F, fixed and f32, counted exactly
#    in a QEMU trace (-singlestep -d exec,nochain) between marker functions, over a 1 s
#    window of a random-PWM recording (many firings, multi-thruster words);
#  - the goals: worst tick < 8,400 instructions on the M4F; fixed >= 5x fewer instructions
#    than soft-float f32 on the M0.
# Needs scripts/setup.sh (targets, nightly rust-src, qemu-system-arm, llvm tools).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
BASE=${CARGO_TARGET_DIR:-$ROOT/target}
OUT=$ROOT/out/kernel
mkdir -p "$OUT"
QBASE=$BASE/qemu
COUNT_RECORDING=${MASSID_COUNT_RECORDING:-$ROOT/../shared/data/open/o03_pressure_drop_combo.csv}
COUNT_WINDOW=${MASSID_COUNT_WINDOW_MS:-1000..2000}
log() { echo "kernel-report: $*" >&2; }

for tool in llvm-size llvm-objdump qemu-system-arm; do
  command -v "$tool" >/dev/null || { echo "kernel-report: $tool not found (run scripts/setup.sh)" >&2; exit 1; }
done

log "building the host tool"
(cd kernel/qemu && CARGO_TARGET_DIR=$QBASE cargo build -q --locked --release -p massid-qemu-host)
HOST_TOOL=$QBASE/release/massid-qemu-host

# ---- code size -------------------------------------------------------------------------
# Sum of .text* sections of the massid_kernel objects in the archive (llvm-size -A output:
# a "NAME (ex ARCHIVE):" line per member, then "section size addr" lines).
kernel_text() {
  llvm-size -A "$1" | awk '
    / \(ex / { member = $1; next }
    member ~ /^massid_kernel/ && $1 ~ /^\.text/ { sum += $2 }
    END { print sum + 0 }'
}
declare -A CODE
log "code size: C-ABI static library per target"
for t in thumbv6m-none-eabi thumbv7em-none-eabihf riscv32imc-unknown-none-elf; do
  CARGO_TARGET_DIR=$BASE cargo build -q --locked --release -p massid-kernel-capi --target "$t"
  CODE[$t]=$(kernel_text "$BASE/$t/release/libmassid_kernel_capi.a")
done
for t in hexagon-unknown-none-elf msp430-none-elf; do
  if CARGO_TARGET_DIR=$BASE/nightly cargo +nightly build -q --locked --release -p massid-kernel-capi \
       --target "$t" -Zbuild-std=core >"$OUT/capi-$t.log" 2>&1; then
    CODE[$t]=$(kernel_text "$BASE/nightly/$t/release/libmassid_kernel_capi.a")
  else
    CODE[$t]="does not build (out/kernel/capi-$t.log)"
  fi
done

# ---- firmware (equality build) and state sizes --------------------------------------------
log "firmware images and state sizes"
# As in cross-check.sh: the micro:bit image at opt-level s, the M4F image at the release profile.
M0BASE=$BASE/qemu-s
(
  cd kernel/qemu
  CARGO_PROFILE_RELEASE_OPT_LEVEL=s CARGO_TARGET_DIR=$M0BASE \
    cargo build -q --locked --release -p massid-qemu-firmware --target thumbv6m-none-eabi
  CARGO_TARGET_DIR=$QBASE cargo build -q --locked --release -p massid-qemu-firmware --target thumbv7em-none-eabihf
)
image_text() { llvm-size "$1" | awk 'NR == 2 { print $1 }'; }
M0_IMAGE=$(image_text "$M0BASE/thumbv6m-none-eabi/release/massid-qemu-firmware")
M4_IMAGE=$(image_text "$QBASE/thumbv7em-none-eabihf/release/massid-qemu-firmware")
timeout 600 qemu-system-arm -machine microbit -semihosting-config enable=on,target=native -nographic \
  -monitor none -serial none -kernel "$M0BASE/thumbv6m-none-eabi/release/massid-qemu-firmware" >"$OUT/qemu-m0.txt"
"$HOST_TOOL" run >"$OUT/host.txt"
info() { awk -v k="$2" -v f="$3" '$1 == "info" && $2 == f && $3 == k { print $4 }' "$1"; }

# ---- stack ----------------------------------------------------------------------------------
ENTRIES=(massid_fixed_init massid_fixed_tick massid_fixed_finish massid_fixed_estimates
         massid_fixed_mixer_from_pipeline massid_fixed_mix
         massid_f32_init massid_f32_tick massid_f32_finish massid_f32_estimates
         massid_f32_mixer_from_pipeline massid_f32_mix
         massid_fixed_craft_mixer_init massid_fixed_craft_mix
         massid_f32_craft_mixer_init massid_f32_craft_mix
         massid_f32_flight_id_init massid_f32_flight_id_push massid_f32_flight_id_push_wrench
         massid_f32_flight_id_finish massid_f32_flight_id_solve massid_f32_flight_id_reanchor
         massid_fixed_flight_id_init massid_fixed_flight_id_push massid_fixed_flight_id_push_wrench
         massid_fixed_flight_id_finish massid_fixed_flight_id_solve)
SBASE=$BASE/qemu-stack
for t in thumbv6m-none-eabi thumbv7em-none-eabihf; do
  log "stack: $t (nightly, -Zemit-stack-sizes)"
  (cd kernel/qemu && CARGO_TARGET_DIR=$SBASE RUSTFLAGS="-Zemit-stack-sizes" cargo +nightly build -q --locked \
     --release -p massid-qemu-firmware --features capi --target "$t")
  elf=$SBASE/$t/release/massid-qemu-firmware
  llvm-objdump -d --no-show-raw-insn "$elf" >"$OUT/stack-$t.objdump.txt"
  "$HOST_TOOL" stack "$elf" "$OUT/stack-$t.objdump.txt" "${ENTRIES[@]}" >"$OUT/stack-$t.tsv"
done
# Bound, marked "(panic path)" when a core::panicking call is reachable (listed below the table).
stack_of() { awk -v e="$2" -F'\t' '$1 == e { print $2 ($3 != "" ? " (panic path)" : "") }' "$OUT/stack-$1.tsv"; }

# ---- instruction counts -------------------------------------------------------------------
CBASE=$BASE/qemu-count
(
  cd kernel/qemu
  # As the equality images: the micro:bit (16 KB RAM) at opt-level s (at opt-level 3 the
  # runner's own frame, which holds the pipeline, no longer fits beside the stack), the M4F at 3.
  MASSID_QEMU_RECORDING=$COUNT_RECORDING MASSID_QEMU_WINDOW_MS=$COUNT_WINDOW MASSID_QEMU_COUNT=1 CARGO_TARGET_DIR=$CBASE \
    CARGO_PROFILE_RELEASE_OPT_LEVEL=s cargo build -q --locked --release -p massid-qemu-firmware --target thumbv6m-none-eabi
  MASSID_QEMU_RECORDING=$COUNT_RECORDING MASSID_QEMU_WINDOW_MS=$COUNT_WINDOW MASSID_QEMU_COUNT=1 CARGO_TARGET_DIR=$CBASE \
    cargo build -q --locked --release -p massid-qemu-firmware --target thumbv7em-none-eabihf
)
# One instruction per translation block: -singlestep up to QEMU 8, the tcg property after.
if qemu-system-arm -accel tcg,help 2>/dev/null | grep -q one-insn-per-tb; then
  ONE_INSN=(-accel tcg,one-insn-per-tb=on)
else
  ONE_INSN=(-singlestep)
fi
count() { # target out-name machine-args...
  local t=$1 name=$2; shift 2
  local elf=$CBASE/$t/release/massid-qemu-firmware
  log "instruction trace: $name (this takes a minute or two)"
  # The exec log goes to stderr (one line per instruction), piped into the counter; the
  # semihosted output goes to a file.
  timeout 1800 qemu-system-arm "$@" -semihosting-config enable=on,target=native -nographic \
    -monitor none -serial none "${ONE_INSN[@]}" -d exec,nochain -D /dev/stderr -kernel "$elf" \
    2>&1 >"$OUT/count-$name.out" | "$HOST_TOOL" count "$elf" "$OUT/profile-$name.tsv" >"$OUT/count-$name.tsv"
  grep -q '^# done' "$OUT/count-$name.out" || { echo "kernel-report: the $name count run did not finish" >&2; exit 1; }
}
if [ "${MASSID_REPORT_REUSE_TRACES:-0}" = 1 ] && [ -s "$OUT/count-m0.tsv" ] && [ -s "$OUT/count-m4f.tsv" ]; then
  log "reusing the previous instruction counts (MASSID_REPORT_REUSE_TRACES=1)"
else
  count thumbv6m-none-eabi m0 -machine microbit
  count thumbv7em-none-eabihf m4f -machine mps2-an386 -cpu cortex-m4
fi
# Fields of count-*.tsv: kind calls min mean max; kind = flavour/what.
cnt() { awk -F'\t' -v k="$2" -v c="$3" '$1 == k { print $c }' "$OUT/count-$1.tsv"; }
# Mean instructions per tick of a flavour over every tick of the window (mixer calls excluded).
mean_tick() {
  awk -F'\t' -v f="$2/" 'index($1, f) == 1 && $1 !~ /mixer|flight_id/ { n += $2; s += $2 * $4 } END { if (n > 0) printf "%d", s / n; else print 0 }' "$OUT/count-$1.tsv"
}
# Worst tick of a flavour's seed pipeline: the largest max over its tick kinds (the mixers run
# once per control period; the output-error identification's push has its own goal row).
worst_tick() {
  awk -F'\t' -v f="$2/" 'index($1, f) == 1 && $1 !~ /mixer|flight_id/ { if ($5 > m) { m = $5; k = $1 } } END { print m + 0, k }' "$OUT/count-$1.tsv"
}

# ---- report -------------------------------------------------------------------------------
{
  echo "## Kernel on embedded targets (measured by \`scripts/kernel-report.sh\`)"
  echo
  echo "### Code size"
  echo
  echo "| target | kernel .text in the C-ABI static library (bytes) |"
  echo "|---|---|"
  for t in thumbv6m-none-eabi thumbv7em-none-eabihf riscv32imc-unknown-none-elf hexagon-unknown-none-elf msp430-none-elf; do
    echo "| \`$t\` | ${CODE[$t]} |"
  done
  echo
  echo "Both instantiations (Q8.24 and f32) of pipeline + mixer, as the C ABI instantiates them, summed over"
  echo "the \`massid_kernel\` objects of \`libmassid_kernel_capi.a\` (release, before link-time garbage collection;"
  echo "\`core\` and \`compiler_builtins\` excluded). Linked QEMU firmware images (kernel fixed + f32, runner,"
  echo "formatting, soft-float, embedded recording): micro:bit (M0, opt-level s) $M0_IMAGE bytes, MPS2-AN386 (M4F, opt-level 3) $M4_IMAGE bytes of text."
  echo
  echo "### State size (bytes, 32-bit targets)"
  echo
  echo "| | fixed (Q8.24) | f32 |"
  echo "|---|---|---|"
  echo "| pipeline (\`Pipeline<S>\`) | $(info "$OUT/qemu-m0.txt" state-bytes fixed) | $(info "$OUT/qemu-m0.txt" state-bytes f32) |"
  echo "| mixer (\`Mixer<S>\`) | $(info "$OUT/qemu-m0.txt" mixer-bytes fixed) | $(info "$OUT/qemu-m0.txt" mixer-bytes f32) |"
  echo
  hdr=kernel/include/massid_kernel.h
  echo "(x86-64 host: pipeline $(info "$OUT/host.txt" state-bytes fixed) bytes; the C ABI reserves $(awk '$2 == "MASSID_PIPELINE_BYTES" { print $3 }' "$hdr") bytes per pipeline block and $(awk '$2 == "MASSID_MIXER_BYTES" { print $3 }' "$hdr") per mixer block.)"
  echo
  echo "### Worst-case stack per C-ABI entry point (bytes)"
  echo
  echo "| entry point | Cortex-M0 | Cortex-M4F |"
  echo "|---|---|---|"
  for e in "${ENTRIES[@]}"; do
    echo "| \`$e\` | $(stack_of thumbv6m-none-eabi "$e") | $(stack_of thumbv7em-none-eabihf "$e") |"
  done
  echo
  echo "Frame sizes from \`-Zemit-stack-sizes\` (nightly), call graph from \`llvm-objdump -d\` of the linked image"
  echo "(\`massid-qemu-host stack\`); precompiled \`compiler_builtins\` functions (soft-float, 64-bit division, memcpy)"
  echo "have no \`.stack_sizes\` entry and are bounded from their prologue (push/vpush/sub sp). Tail calls counted as calls."
  echo "Calls into \`core::panicking\` (which never return) are not followed; where the compiler left one reachable"
  echo "the entry point is marked \"(panic path)\" and the call sites are:"
  echo
  for t in thumbv6m-none-eabi thumbv7em-none-eabihf; do
    sites=$(awk -F'\t' '$3 != "" { sub(/^panic path reachable: /, "", $3); n = split($3, a, "; "); for (i = 1; i <= n; i++) print a[i] }' "$OUT/stack-$t.tsv" | sort -u | paste -sd ';' | sed 's/;/; /g')
    echo "- \`$t\`: ${sites:-none}"
  done
  echo
  echo "### Instructions per call (exact, QEMU trace)"
  echo
  echo "Window \`$(basename "$COUNT_RECORDING")\` $COUNT_WINDOW ms (1 kHz ticks; random PWM, 1-4 thrusters), \`PipelineConfig::seed(1)\`"
  echo "with forgetting 0.9999 and the change detector (the most work per firing); M0 image at opt-level s, M4F at 3. Kinds:"
  echo "idle = thrusters off or valve transient; edge = the tick of a thruster-word change (firing ends/starts) without a solve;
deferred = ticks 1-8 after a word change (thrusters off or valve transient) that ran no deferred stage;
deferred_<stage> = a tick that ran that end-of-firing stage (\`Pipeline::pending_stage\`; the last stage, the inverse-inertia solve, is \`solve\`);"
  echo "kf = Kalman update during the batch firings; kf_rls = Kalman update + RLS measurement (firing 3 on);"
  echo "solve = end of firing with the batch/RLS LU solve; mixer_build = mixer rebuilt from the CoM estimate; mixer = one mix;"
  echo "craft_mixer_<craft> = one mix by the any-craft mixer (\`massid_kernel::craft_mixer\`: pair rules for sph2, non-negative allocation for"
  echo "the 8-thruster planar air-bearing craft and the 16-thruster free-flyer of \`examples/models/\`), once per control period, not per tick;"
  echo "flight_id_push = one sample of the output-error identification (\`massid_kernel::flight_id\`): f32 on hard-float targets; fixed is"
  echo "the integer float \`massid_kernel::IntFloat\` over the first 150 samples (its trace is slow; M4F only: its 29 kB state does not fit the micro:bit M0's 16 kB of RAM);"
  echo "flight_id_push_<craft> = the same for the air-bearing craft (planar, 8 thrusters; airbearing_mocap: with motion-capture rates, the moving-average filter on) and the 16-thruster free-flyer, 500 samples (f32) / 150 (fixed)"
  echo "of the window driving the craft's own thrusters (the free-flyer's 16 from the 12-bit word spread by 4 bits; sums only)."
  echo "The fit (SPHERES) runs outside the tick and is not counted; a push's min is a window's first samples, left out of the sums."
  echo "flight_id_close[_<craft>] = the window close: the push of a missing sample mid-flight, which closes the window and queues its initial-rate term (\`flight_id::close\`: the pushes after it add it 8 entries each, so the push rows include that), once per craft; \`FlightId::finish\` at the end of the flight adds what is left (not a tick, not counted)."
  echo
  echo "| call | M0 fixed mean / max | M0 f32 mean / max | M4F fixed mean / max | M4F f32 mean / max | calls (fixed) |"
  echo "|---|---|---|---|---|---|"
  for k in idle edge deferred deferred_measure deferred_aggregate deferred_fold_com deferred_plan_inertia deferred_fold_inertia deferred_detect deferred_detect_finish \
           deferred_merge_inertia deferred_merge_com deferred_solve_com deferred_factor_inertia kf kf_rls solve flight_id_push flight_id_push_airbearing flight_id_push_airbearing_mocap flight_id_push_freeflyer16 flight_id_close flight_id_close_airbearing flight_id_close_airbearing_mocap flight_id_close_freeflyer16 mixer_build mixer craft_mixer_sph2 craft_mixer_airbearing craft_mixer_freeflyer16 other; do
    [ -n "$(cnt m0 "fixed/$k" 2)$(cnt m0 "f32/$k" 2)" ] || continue
    echo "| $k | $(cnt m0 "fixed/$k" 4) / $(cnt m0 "fixed/$k" 5) | $(cnt m0 "f32/$k" 4) / $(cnt m0 "f32/$k" 5) | $(cnt m4f "fixed/$k" 4) / $(cnt m4f "fixed/$k" 5) | $(cnt m4f "f32/$k" 4) / $(cnt m4f "f32/$k" 5) | $(cnt m0 "fixed/$k" 2) |"
  done
  echo
  read -r m4_f32 m4_f32_kind <<<"$(worst_tick m4f f32)"
  read -r m4_fix m4_fix_kind <<<"$(worst_tick m4f fixed)"
  read -r m0_f32 _ <<<"$(worst_tick m0 f32)"
  read -r m0_fix _ <<<"$(worst_tick m0 fixed)"
  verdict() { if [ "$1" -lt "$2" ]; then echo "met"; else echo "**missed**"; fi; }
  echo "### Goals"
  echo
  echo "| goal | measured | |"
  echo "|---|---|---|"
  echo "| worst tick (incl. RLS update and solve) < 8,400 instructions on the M4F, f32 | $m4_f32 ($m4_f32_kind) | $(verdict "$m4_f32" 8400) |"
  echo "| worst tick < 8,400 instructions on the M4F, fixed | $m4_fix ($m4_fix_kind) | $(verdict "$m4_fix" 8400) |"
  # Per craft, the identification's push (worst sample) and window close.
  for call in "push:worst sample" "close:window close"; do
    for craft in sph2 airbearing airbearing_mocap freeflyer16; do
      k=flight_id_${call%%:*}; [ "$craft" = sph2 ] || k=${k}_$craft
      for f in f32 fixed; do
        n=$(cnt m4f "$f/$k" 5)
        [ -z "$n" ] || echo "| output-error identification, $craft, ${call#*:} < 8,400 instructions on the M4F, $f | $n | $(verdict "$n" 8400) |"
      done
    done
  done
  mean_fix=$(mean_tick m0 fixed); mean_f32=$(mean_tick m0 f32)
  if [ "$mean_fix" -gt 0 ]; then
    ratio=$(awk -v a="$mean_f32" -v b="$mean_fix" 'BEGIN { printf "%.2f", a / b }')
    ok=$(awk -v r="$ratio" 'BEGIN { print (r >= 5) ? "met" : "**missed**" }')
    echo "| fixed >= 5x fewer instructions than soft-float f32 on the M0 (mean over all ticks of the window) | f32 $mean_f32 / fixed $mean_fix = ${ratio}x | $ok |"
  fi
  ratio_w=$(awk -v a="$m0_f32" -v b="$m0_fix" 'BEGIN { if (b > 0) printf "%.2f", a / b; else print "n/a" }')
  echo "| same, worst tick | f32 $m0_f32 / fixed $m0_fix = ${ratio_w}x | $(awk -v r="$ratio_w" 'BEGIN { print (r + 0 >= 5) ? "met" : "**missed**" }') |"
  echo
  echo "### Where the instructions go (the worst tick's kind, top functions by share)"
  echo
  echo "Per-function split of the same traces (PC -> function symbol of the linked, LTO-inlined image;"
  echo "the runner's functions \`massid_qemu_runner::run\`/\`run_all\`/\`__cortex_m_rt_main\` hold kernel code that LTO inlined"
  echo "into the loop, mostly \`Pipeline::step\`; \`__aeabi_lmul\` is the 64-bit multiply the Cortex-M0 lacks in hardware)."
  echo
  echo "| core, kernel, tick kind | share | instructions (all calls of the kind) | function |"
  echo "|---|---|---|---|"
  for name in m4f m0; do
    for f in fixed f32; do
      read -r _ kind <<<"$(worst_tick "$name" "$f")"
      awk -F'\t' -v k="$kind" -v n="$name" '$1 == k && shown < 6 { shown++; printf "| %s %s | %s %% | %s | `%s` |\n", n, k, $2, $3, $4 }' "$OUT/profile-$name.tsv"
    done
  done
} | tee "$OUT/report.md"
