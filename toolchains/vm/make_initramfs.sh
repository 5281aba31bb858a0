#!/usr/bin/env bash
# Builds the base initramfs of the hardware-test VM: static busybox, the vivid module with every module it
# depends on (resolved from modules.dep), and an /init that loads them, mounts /proc, /sys and /dev, runs
# /qsg/run.sh (added by a second archive, see run_hardware_tests.sh) and powers the VM off.
#
#   toolchains/vm/make_initramfs.sh [VM_DIR]      VM_DIR: $QSG_VM_DIR, else build/vm; after fetch_kernel.sh
#
# Writes VM_DIR/initramfs-base.cpio.gz (about 1.5 MB). Rebuilt every time: it takes well under a second.
# Environment: QSG_VM_MODULES (default "vivid") names the modules to load; each one's dependencies are found
# in modules.dep and loaded first. QSG_VIVID_OPTIONS are vivid's module parameters (default
# "n_devs=1 node_types=0x1": one instance with only its video capture node, /dev/video0; set it empty for
# vivid's defaults, which add output and metadata nodes as /dev/video1..3).
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
vm_dir=${1:-${QSG_VM_DIR:-$root/build/vm}}
modules=${QSG_VM_MODULES:-vivid}
vivid_options=${QSG_VIVID_OPTIONS-n_devs=1 node_types=0x1}

log() { echo "make_initramfs: $*"; }
die() { echo "make_initramfs: error: $*" >&2; exit 1; }

kernel=$vm_dir/kernel
[[ -f "$kernel/release" && -x "$kernel/busybox" ]] ||
  die "no kernel in $kernel: run toolchains/vm/fetch_kernel.sh first"
release=$(cat "$kernel/release")
mod_root=$kernel/root/lib/modules/$release
dep_file=$mod_root/modules.dep
[[ -f "$dep_file" ]] || die "$dep_file is missing: rerun toolchains/vm/fetch_kernel.sh"
command -v cpio > /dev/null || die "cpio not found: install cpio (toolchains/install_deps.sh --cross does)"

# modules.dep: "kernel/path/name.ko: dep.ko dep.ko ..." with paths relative to the release directory.
declare -A deps_of=() path_of=()
while IFS= read -r line; do
  path=${line%%:*}
  name=${path##*/}
  name=${name%.ko}
  name=${name//-/_}
  path_of[$name]=$path
  deps_of[$path]=${line#*:}
done < "$dep_file"

# Depth-first: every module's dependencies go into the load order before the module itself.
declare -A placed=()
order=()
place() {
  local p=$1 d
  [[ -n "${placed[$p]:-}" ]] && return 0
  placed[$p]=1
  for d in ${deps_of[$p]:-}; do place "$d"; done
  order+=("$p")
}
for m in $modules; do
  key=${m//-/_}
  [[ -n "${path_of[$key]:-}" ]] || die "module '$m' is not in $dep_file (kernel $release)"
  place "${path_of[$key]}"
done

stage=$(mktemp -d "${TMPDIR:-/tmp}/qsg-initramfs.XXXXXX")
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage"/{bin,dev,proc,sys,tmp,etc,qsg,"lib/modules/$release"}
cp "$kernel/busybox" "$stage/bin/busybox"
ln -s busybox "$stage/bin/sh"
: > "$stage/etc/qsg-modules"
for p in "${order[@]}"; do
  mkdir -p "$stage/lib/modules/$release/$(dirname "$p")"
  cp "$mod_root/$p" "$stage/lib/modules/$release/$p"
  args=""
  [[ "$(basename "$p")" == vivid.ko ]] && args=$vivid_options
  echo "$release/$p $args" >> "$stage/etc/qsg-modules"
done

cat > "$stage/init" << 'EOF'
#!/bin/busybox sh
# PID 1 of the hardware-test VM: loads the modules, mounts the kernel file systems, runs /qsg/run.sh and
# powers off. Any failure is printed on the console; the host script judges the run from those lines.
/bin/busybox mount -t proc proc /proc
/bin/busybox --install -s /bin
export PATH=/bin
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev
mount -t tmpfs tmpfs /tmp
echo "qsg-vm: kernel $(uname -r) $(uname -m), $(nproc) cpus, $(awk '/MemTotal/ {print int($2 / 1024) " MB"}' /proc/meminfo), /init at $(cut -d ' ' -f 1 /proc/uptime) s"
while read -r module args; do
  [ -n "$module" ] || continue
  if insmod "/lib/modules/$module" $args; then
    echo "qsg-vm: loaded $(basename "$module") $args"
  else
    echo "QSG-VM-ERROR: insmod /lib/modules/$module $args failed"
  fi
done < /etc/qsg-modules
if [ -x /qsg/run.sh ]; then
  /qsg/run.sh
  echo "qsg-vm: /qsg/run.sh exited with $?"
else
  echo "QSG-VM-ERROR: no /qsg/run.sh in the initramfs"
fi
echo "qsg-vm: powering off at $(cut -d " " -f 1 /proc/uptime) s"
sync
poweroff -f
EOF
chmod 755 "$stage/init"

out=$vm_dir/initramfs-base.cpio.gz
(cd "$stage" && find . -mindepth 1 | LC_ALL=C sort | cpio --quiet -o -H newc -R 0:0 | gzip -6 -n) > "$out.tmp"
mv "$out.tmp" "$out"
log "$out: kernel $release, ${#order[@]} modules (${order[*]##*/}), $(du -k "$out" | cut -f1) KiB"
