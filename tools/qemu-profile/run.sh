#!/bin/sh
# Profiles the bench firmware under QEMU, instructions per function, per epoch (see
# profile.c and symbols.py). Usage, from the repository's root:
#   tools/qemu-profile/run.sh [--features compact] [SELECT [TOP]]
# Needs a C compiler and qemu-system-arm 7.2 (plugins enabled, as Debian's is).
set -e
here=$(cd "$(dirname "$0")" && pwd)
features=""
if [ "$1" = "--features" ]; then features="--features $2"; shift 2; fi
out=${QPROF_DIR:-target/qemu-profile}
mkdir -p "$out"
cc -shared -fPIC -O2 -o "$out/libprofile.so" "$here/profile.c"
cargo build -q --release -p hollowpath-qemu --target thumbv7em-none-eabihf $features
elf=target/thumbv7em-none-eabihf/release/hollowpath-qemu
marker=$(nm "$elf" | awk '/hstdout_fmt/ { print $1; exit }')
QPROF_OUT="$out/profile.out" qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic \
    -monitor none -semihosting-config enable=on,target=native -icount shift=0 \
    -plugin "$out/libprofile.so,marker=$marker" -kernel "$elf" > "$out/firmware.log"
python3 "$here/symbols.py" "$elf" "$out/profile.out" "$out/firmware.log" "$@"
