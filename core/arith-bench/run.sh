#!/usr/bin/env bash
# Instructions per pixel of every decoding backend on Cortex-M3 (thumbv7m-none-eabi, no FPU: f32 in
# software) and Cortex-M4F (thumbv7em-none-eabihf) under QEMU, counted by the plugin in qemu/.
#
#     ./run.sh                 # all backends, cases 0 (paper set, u8) and 2 (paper set, u16)
#     REPS=8 CASES="0 3" ./run.sh
#     BACKENDS=" " ./run.sh    # the compiled reconstruction only
#
# Per pixel = (count with REPS decodes − count with 0 decodes) / (REPS · 256 pixels): the set-up
# (input synthesis in soft f64, decoder construction, digest) cancels. Needs qemu-system-arm, a C
# compiler and the two rustup targets.
set -euo pipefail
cd "$(dirname "$0")"
TD=${CARGO_TARGET_DIR:-target}
mkdir -p "$TD"
PLUGIN=$(cd "$TD" && pwd)/libinsn_count.so
cc -shared -fPIC -O2 -o "$PLUGIN" qemu/insn_count.c
REPS=${REPS:-4}
CASES=${CASES:-"0 2"}
BACKENDS=${BACKENDS:-"f32 f32-fast f32-micromath fixed"}
WIDTH=256
for spec in thumbv7m-none-eabi:mps2-an385:cortex-m3 thumbv7em-none-eabihf:mps2-an386:cortex-m4; do
  IFS=: read -r target machine cpu <<<"$spec"
  cargo build --quiet --release --target "$target"
  elf=$TD/$target/release/fringe3d-arith-bench
  count() {
    qemu-system-arm -machine "$machine" -cpu "$cpu" -nographic \
      -semihosting-config "enable=on,target=native,arg=bench,arg=count,arg=$1,arg=$2,arg=$3" \
      -plugin "$PLUGIN" -d plugin -kernel "$elf" 2>&1 | sed -n 's/^insns: //p'
  }
  for b in $BACKENDS; do
    for c in $CASES; do
      n0=$(count "$b" "$c" 0)
      n1=$(count "$b" "$c" "$REPS")
      echo "$target $machine $b case $c: $(((n1 - n0) / (REPS * WIDTH))) instructions/pixel"
    done
  done
  # The compiled reconstruction (core/src/reconstruct/compiled/parity.rs, 256 pixels a row):
  # the kernel alone, then as a head runs it, from the row's bytes in its store (the conversion
  # first), then as at a head's first scan of new models (the conversion and the settle).
  ccount() {
    qemu-system-arm -machine "$machine" -cpu "$cpu" -nographic \
      -semihosting-config "enable=on,target=native,arg=bench,arg=$1,arg=$2" \
      -plugin "$PLUGIN" -d plugin -kernel "$elf" 2>&1 | sed -n 's/^insns: //p'
  }
  n0=$(ccount count-compiled 0)
  n1=$(ccount count-compiled "$REPS")
  echo "$target $machine compiled reconstruction: $(((n1 - n0) / (REPS * WIDTH))) instructions/pixel"
  n0=$(ccount count-compiled-bytes 0)
  n1=$(ccount count-compiled-bytes "$REPS")
  echo "$target $machine compiled reconstruction from the row's bytes: $(((n1 - n0) / (REPS * WIDTH))) instructions/pixel"
  n0=$(ccount count-compiled-settle 0)
  n1=$(ccount count-compiled-settle "$REPS")
  echo "$target $machine compiled reconstruction from the row's bytes, settled: $(((n1 - n0) / (REPS * WIDTH))) instructions/pixel"
done
