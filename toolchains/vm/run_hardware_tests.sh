#!/usr/bin/env bash
# Runs the cross-built V4L2 and GPIO hardware suites against real kernel drivers: boots Debian's arm64 kernel
# under qemu-system-aarch64 (software emulation), loads vivid (/dev/video0) and uses the virt board's PL061
# (/dev/gpiochip0), then reports each suite's gtest output and exit code from the serial console.
#
#   toolchains/vm/run_hardware_tests.sh BUILD_DIR        e.g. build/arm64 (the arm64 preset's tree)
#
# Exits 0 when both suites pass with nothing skipped; 1 when a suite fails, skips, or never reports (VM
# crash); 2 on bad setup; 3 when the VM times out. The serial console is also saved to VM_DIR/serial.log.
# The binaries and the shared libraries they need (from the arm64 sysroot the build used) are packed into a
# second initramfs archive, so the VM needs neither a disk nor a shared folder.
#
# Environment (all optional):
#   QSG_VM_DIR        work and cache directory (default build/vm in the repository)
#   QSG_SYSROOT       arm64 sysroot holding the libraries (default: CMAKE_SYSROOT from BUILD_DIR's cache)
#   QSG_VM_TIMEOUT_S  wall-clock limit of the VM (default 600)
#   QSG_VM_CPU, QSG_VM_SMP, QSG_VM_MEMORY_MB   qemu -cpu / -smp / -m (default cortex-a57, 2, 1024)
#   QSG_V4L2_FRAMES   frames the streaming test takes (default 30; vivid gives about 5 fps under emulation)
#   QSG_GPIO_LINE     PL061 line the GPIO suite drives (default 0; line 3 is the virt board's power button)
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)

log() { echo "run_hardware_tests: $*"; }
die() { echo "run_hardware_tests: error: $*" >&2; exit 2; }

[[ $# == 1 ]] || { sed -n '2,19p' "$0" >&2; exit 2; }
build_dir=$1
[[ -d "$build_dir" ]] || die "build directory '$build_dir' does not exist (build it: cmake --preset arm64 && cmake --build --preset arm64)"
build_dir=$(cd "$build_dir" && pwd)
vm_dir=${QSG_VM_DIR:-$root/build/vm}
timeout_s=${QSG_VM_TIMEOUT_S:-600}
frames=${QSG_V4L2_FRAMES:-30}
gpio_line=${QSG_GPIO_LINE:-0}
[[ "$timeout_s" =~ ^[0-9]+$ && "$frames" =~ ^[0-9]+$ && "$gpio_line" =~ ^[0-9]+$ ]] ||
  die "QSG_VM_TIMEOUT_S, QSG_V4L2_FRAMES and QSG_GPIO_LINE must be whole numbers"

# name, path in the build tree, environment inside the VM
suites=(qsg_v4l2_hardware_tests qsg_gpio_hardware_tests)
declare -A suite_path=(
  [qsg_v4l2_hardware_tests]=tests/drivers/v4l2/qsg_v4l2_hardware_tests
  [qsg_gpio_hardware_tests]=tests/drivers/gpio/qsg_gpio_hardware_tests
)
declare -A suite_env=(
  [qsg_v4l2_hardware_tests]="QSG_V4L2_DEVICE=/dev/video0 QSG_V4L2_FRAMES=$frames"
  [qsg_gpio_hardware_tests]="QSG_GPIO_CHIP=/dev/gpiochip0 QSG_GPIO_LINE=$gpio_line"
)

qemu=$(command -v qemu-system-aarch64) ||
  die "qemu-system-aarch64 not found: install qemu-system-arm (toolchains/install_deps.sh --cross does)"
command -v cpio > /dev/null || die "cpio not found (toolchains/install_deps.sh --cross installs it)"
readelf=$(command -v aarch64-linux-gnu-readelf || command -v readelf) ||
  die "readelf not found: install binutils-aarch64-linux-gnu"

is_aarch64() { "$readelf" -h "$1" 2> /dev/null | grep -q 'Machine:.*AArch64'; }
for s in "${suites[@]}"; do
  bin=$build_dir/${suite_path[$s]}
  [[ -x "$bin" ]] || die "$bin is missing: cmake --build --preset arm64 --target ${suites[*]}"
  is_aarch64 "$bin" || die "$bin is not an AArch64 executable (is $build_dir the arm64 build?)"
done

sysroot=${QSG_SYSROOT:-}
if [[ -z "$sysroot" && -f "$build_dir/CMakeCache.txt" ]]; then
  sysroot=$(sed -n 's/^CMAKE_SYSROOT:[A-Z]*=//p' "$build_dir/CMakeCache.txt" | head -n 1)
fi
[[ -n "$sysroot" ]] || die "no sysroot: $build_dir/CMakeCache.txt has no CMAKE_SYSROOT; set QSG_SYSROOT"
[[ -d "$sysroot/usr/lib/aarch64-linux-gnu" ]] || die "sysroot '$sysroot' has no usr/lib/aarch64-linux-gnu"

mkdir -p "$vm_dir"
vm_dir=$(cd "$vm_dir" && pwd)
"$here/fetch_kernel.sh" "$vm_dir"
"$here/make_initramfs.sh" "$vm_dir"

# Second archive: /qsg/bin (the suites), /qsg/lib (their libraries), the loader, and /qsg/run.sh.
stage=$(mktemp -d "${TMPDIR:-/tmp}/qsg-vm-tests.XXXXXX")
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage/qsg/bin" "$stage/qsg/lib" "$stage/lib"
lib_dirs=("$sysroot/usr/lib/aarch64-linux-gnu" "$sysroot/lib/aarch64-linux-gnu" "$sysroot/usr/lib" "$sysroot/lib")
declare -A copied=()
copy_needed() {  # copy_needed ELF: copies the libraries ELF needs, recursively, into /qsg/lib
  local lib dir found
  for lib in $("$readelf" -d "$1" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p'); do
    [[ -n "${copied[$lib]:-}" ]] && continue
    found=""
    for dir in "${lib_dirs[@]}"; do
      if [[ -e "$dir/$lib" ]]; then found=$dir/$lib; break; fi
    done
    [[ -n "$found" ]] || die "$lib (needed by $(basename "$1")) is not in the sysroot $sysroot"
    cp -L "$found" "$stage/qsg/lib/$lib"
    # A link that escaped into the host would bring an x86 library along: refuse it.
    is_aarch64 "$stage/qsg/lib/$lib" || die "$found is not an AArch64 library (a link pointing into the host?)"
    copied[$lib]=1
    copy_needed "$stage/qsg/lib/$lib"
  done
}
for s in "${suites[@]}"; do
  bin=$build_dir/${suite_path[$s]}
  cp "$bin" "$stage/qsg/bin/$s"
  copy_needed "$bin"
  interp=$("$readelf" -l "$bin" | sed -n 's/.*Requesting program interpreter: \(.*\)\]/\1/p')
  [[ "$interp" == /lib/* ]] || die "$bin asks for the loader '$interp' (expected /lib/ld-linux-aarch64.so.1)"
  if [[ ! -e "$stage$interp" ]]; then
    cp -L "$sysroot$interp" "$stage$interp" || die "the loader $interp is not in the sysroot $sysroot"
    is_aarch64 "$stage$interp" || die "$sysroot$interp is not an AArch64 loader"
  fi
done

run_sh=$stage/qsg/run.sh
cat > "$run_sh" << 'EOF'
#!/bin/sh
# Written by toolchains/vm/run_hardware_tests.sh: names the devices, runs each suite, prints its exit code.
export LD_LIBRARY_PATH=/qsg/lib
echo "qsg-vm: devices: $(ls /dev/video* /dev/gpiochip* 2> /dev/null | tr '\n' ' ')"
for v in /sys/class/video4linux/video*; do
  [ -e "$v/name" ] && echo "qsg-vm: ${v##*/} is $(cat "$v/name")"
done
for g in /sys/bus/gpio/devices/gpiochip*; do
  [ -e "$g" ] && echo "qsg-vm: ${g##*/} is $(readlink -f "$g" | sed 's|/sys/devices/platform/||')"
done
EOF
for s in "${suites[@]}"; do
  cat >> "$run_sh" << EOF
echo 'QSG-VM-SUITE-BEGIN $s (${suite_env[$s]})'
env ${suite_env[$s]} /qsg/bin/$s --gtest_color=no
echo "QSG-VM-SUITE-END $s exit=\$?"
EOF
done
cat >> "$run_sh" << 'EOF'
# The PL061's lines after the suites released theirs.
mount -t debugfs debugfs /sys/kernel/debug 2> /dev/null && cat /sys/kernel/debug/gpio
echo QSG-VM-DONE
EOF
chmod 755 "$run_sh"

initramfs=$vm_dir/initramfs.cpio.gz
# The kernel unpacks concatenated archives in order; the second adds its files to the first's tree.
(cd "$stage" && find . -mindepth 1 | LC_ALL=C sort | cpio --quiet -o -H newc -R 0:0 | gzip -6 -n) > "$vm_dir/initramfs-tests.cpio.gz"
cat "$vm_dir/initramfs-base.cpio.gz" "$vm_dir/initramfs-tests.cpio.gz" > "$initramfs"
log "initramfs $initramfs: $(du -k "$initramfs" | cut -f1) KiB (libraries: ${!copied[*]})"

serial_log=$vm_dir/serial.log
qemu_cmd=("$qemu" -M virt -cpu "${QSG_VM_CPU:-cortex-a57}" -smp "${QSG_VM_SMP:-2}" -m "${QSG_VM_MEMORY_MB:-1024}"
          -nodefaults -no-user-config -display none -serial stdio -no-reboot
          -kernel "$vm_dir/kernel/vmlinuz" -initrd "$initramfs"
          -append "console=ttyAMA0 rdinit=/init panic=-1 quiet")
log "booting: ${qemu_cmd[*]}"
log "timeout ${timeout_s} s; serial console follows (also in $serial_log)"
boot_start=$SECONDS
set +e
# stdin from /dev/null: qemu leaves the terminal alone; --foreground: Ctrl-C reaches qemu.
timeout --foreground -k 10 "$timeout_s" "${qemu_cmd[@]}" < /dev/null 2>&1 | tee "$serial_log.raw"
qemu_status=${PIPESTATUS[0]}
set -e
vm_s=$((SECONDS - boot_start))
tr -d '\r' < "$serial_log.raw" > "$serial_log"
rm -f "$serial_log.raw"
echo
if (( qemu_status == 124 || qemu_status == 137 )); then
  echo "run_hardware_tests: FAILED: the VM did not power off within ${timeout_s} s (QSG_VM_TIMEOUT_S);" \
       "last console lines:" >&2
  tail -n 15 "$serial_log" | sed 's/^/    /' >&2
  exit 3
fi

failed=0
if (( qemu_status != 0 )); then
  echo "run_hardware_tests: FAILED: qemu-system-aarch64 exited with status $qemu_status" >&2
  failed=1
fi
if grep -q '^QSG-VM-ERROR' "$serial_log"; then
  grep '^QSG-VM-ERROR' "$serial_log" | sed 's/^/run_hardware_tests: FAILED: /' >&2
  failed=1
fi
for s in "${suites[@]}"; do
  end=$(sed -n "s/^QSG-VM-SUITE-END $s exit=\([0-9]*\)\$/\1/p" "$serial_log" | tail -n 1)
  section=$(sed -n "/^QSG-VM-SUITE-BEGIN $s /,/^QSG-VM-SUITE-END $s /p" "$serial_log")
  summary=$(grep -E '^\[  (PASSED  |FAILED  |SKIPPED )\] [0-9]+ test' <<< "$section" | tr '\n' ' ' || true)
  if [[ -z "$end" ]]; then
    echo "run_hardware_tests: FAILED: $s never reported an exit code (crashed VM or killed suite)" >&2
    failed=1
  elif [[ "$end" != 0 ]]; then
    echo "run_hardware_tests: FAILED: $s exited with $end: $summary" >&2
    failed=1
  elif grep -q '^\[  SKIPPED \]' <<< "$section"; then
    # With the device variables set nothing may skip: a skip here means the VM's devices were not usable.
    echo "run_hardware_tests: FAILED: $s skipped tests on the real drivers: $summary" >&2
    failed=1
  else
    log "$s passed: $summary"
  fi
done
if ! grep -q '^QSG-VM-DONE' "$serial_log"; then
  echo "run_hardware_tests: FAILED: the VM's run script did not finish (see $serial_log)" >&2
  failed=1
fi
log "VM ran ${vm_s} s, ${SECONDS} s in all (kernel fetch, initramfs, boot, suites, power-off)"
exit "$failed"
