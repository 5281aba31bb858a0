#!/usr/bin/env bash
# Fetches Debian bookworm's arm64 kernel (image and modules) and arm64 busybox-static as .debs from the host's
# own Debian archive and unpacks them under build/vm/, for the qemu-system-aarch64 hardware-test VM.
#
#   toolchains/vm/fetch_kernel.sh [VM_DIR]          VM_DIR: $QSG_VM_DIR, else build/vm
#
# Result (reused by later runs without touching the network; delete VM_DIR/kernel to refetch):
#   VM_DIR/kernel/vmlinuz                  the kernel image (an uncompressed arm64 Image)
#   VM_DIR/kernel/root/lib/modules/VER/    its modules, with modules.dep made by depmod
#   VM_DIR/kernel/busybox                  the static arm64 busybox
#   VM_DIR/kernel/release                  VER (e.g. 6.1.0-50-arm64)
#
# apt runs with a private state under VM_DIR/apt (APT::Architecture arm64, the host's mirror, Debian's
# archive keyring; deleted once the kernel is unpacked), so the host needs no arm64 dpkg architecture and
# its own apt lists stay untouched.
# Environment: QSG_VM_KERNEL_PACKAGE pins the image package (default: whatever linux-image-arm64 depends on).
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
vm_dir=${1:-${QSG_VM_DIR:-$root/build/vm}}
mkdir -p "$vm_dir"
vm_dir=$(cd "$vm_dir" && pwd)
out=$vm_dir/kernel
stamp=$out/.fetch-stamp
want_package=${QSG_VM_KERNEL_PACKAGE:-}

log() { echo "fetch_kernel: $*"; }
die() { echo "fetch_kernel: error: $*" >&2; exit 1; }

if [[ -f "$stamp" && -f "$out/vmlinuz" && -x "$out/busybox" && -f "$out/release" ]]; then
  release=$(cat "$out/release")
  if [[ -z "$want_package" || "$(sed -n 1p "$stamp")" == "$want_package" ]] &&
     [[ -f "$out/root/lib/modules/$release/modules.dep" ]]; then
    log "cached: kernel $release in $out (delete it to refetch)"
    exit 0
  fi
fi

for tool in apt-get apt-cache dpkg-deb; do
  command -v "$tool" > /dev/null || die "'$tool' not found (this needs a Debian host)"
done
depmod=$(PATH="$PATH:/usr/sbin:/sbin" command -v depmod) ||
  die "depmod not found: install kmod (toolchains/install_deps.sh --cross does)"
keyring=/usr/share/keyrings/debian-archive-keyring.gpg
[[ -f "$keyring" ]] || die "$keyring is missing: install debian-archive-keyring"

# The Debian archive the host already uses (deb822 or one-line sources), as in toolchains/make_sysroot.sh.
mirror=""
if [[ -f /etc/apt/sources.list.d/debian.sources ]]; then
  mirror=$(awk '/^URIs:/ && $2 !~ /security/ {print $2; exit}' /etc/apt/sources.list.d/debian.sources)
fi
if [[ -z "$mirror" && -f /etc/apt/sources.list ]]; then
  mirror=$(awk '$1 == "deb" && $0 !~ /security/ {for (i = 2; i <= NF; ++i) if ($i ~ /^[a-z]+:\/\//) {print $i; exit}}' /etc/apt/sources.list)
fi
[[ -n "$mirror" ]] || die "no Debian archive found in the host's apt sources (/etc/apt/sources.list.d/debian.sources or /etc/apt/sources.list)"

apt_dir=$vm_dir/apt
mkdir -p "$apt_dir"/{lists/partial,archives/partial,etc/apt.conf.d,etc/preferences.d,etc/sources.list.d}
: > "$apt_dir/status"
echo "deb [arch=arm64 signed-by=$keyring] $mirror bookworm main" > "$apt_dir/etc/sources.list"
# Everything apt reads or writes points into apt_dir; the host's /etc/apt configuration is not read.
cat > "$apt_dir/apt.conf" << EOF
APT::Architecture "arm64";
APT::Architectures { "arm64"; };
Dir::State "$apt_dir";
Dir::State::Lists "$apt_dir/lists";
Dir::State::status "$apt_dir/status";
Dir::Cache "$apt_dir";
Dir::Cache::archives "$apt_dir/archives";
Dir::Etc "$apt_dir/etc";
Dir::Etc::SourceList "$apt_dir/etc/sources.list";
Dir::Etc::SourceParts "$apt_dir/etc/sources.list.d";
Dir::Etc::Parts "$apt_dir/etc/apt.conf.d";
Dir::Etc::Preferences "$apt_dir/etc/preferences";
Dir::Etc::PreferencesParts "$apt_dir/etc/preferences.d";
Acquire::Check-Valid-Until "false";
Acquire::Languages "none";
Acquire::Retries "3";
APT::Sandbox::User "root";
EOF
export APT_CONFIG=$apt_dir/apt.conf
start=$SECONDS
log "arm64 package lists from $mirror (private apt state in $apt_dir)"
apt-get -q update > "$apt_dir/update.log" 2>&1 || { cat "$apt_dir/update.log" >&2; die "apt-get update failed"; }

package=$want_package
if [[ -z "$package" ]]; then
  package=$(apt-cache depends linux-image-arm64 | awk '$1 == "Depends:" && $2 ~ /^linux-image-/ {print $2; exit}')
  [[ -n "$package" ]] || die "cannot resolve linux-image-arm64 to a kernel package (apt-cache depends gave nothing)"
fi
log "downloading $package and busybox-static (arm64)"
debs=$vm_dir/debs
rm -rf "$debs"
mkdir -p "$debs"
(cd "$debs" && apt-get -q download "$package" busybox-static > "$debs/download.log" 2>&1) ||
  { cat "$debs/download.log" >&2; die "apt-get download $package busybox-static failed"; }

rm -rf "$out"
mkdir -p "$out/root" "$out/busybox-root"
shopt -s nullglob
kernel_debs=("$debs/${package}"_*_arm64.deb)
busybox_debs=("$debs"/busybox-static_*_arm64.deb)
shopt -u nullglob
(( ${#kernel_debs[@]} == 1 && ${#busybox_debs[@]} == 1 )) || die "downloaded .debs not found in $debs"
kernel_deb=${kernel_debs[0]} busybox_deb=${busybox_debs[0]}
dpkg-deb -x "$kernel_deb" "$out/root"
dpkg-deb -x "$busybox_deb" "$out/busybox-root"

releases=("$out"/root/lib/modules/*)
release=$(basename "${releases[0]}")
[[ ${#releases[@]} == 1 && -f "$out/root/boot/vmlinuz-$release" ]] || die "$kernel_deb holds no boot/vmlinuz-<release>"
mv "$out/root/boot/vmlinuz-$release" "$out/vmlinuz"
mv "$out/busybox-root/bin/busybox" "$out/busybox"
# Reruns never ask apt again (the stamp), so its lists and caches (about 120 MB) go too.
rm -rf "$out/busybox-root" "$debs" "$apt_dir"
# The .deb ships no modules.dep (its postinst runs depmod); make it here, against the unpacked tree.
"$depmod" -b "$out/root" "$release"
[[ -s "$out/root/lib/modules/$release/modules.dep" ]] || die "depmod wrote no modules.dep for $release"
echo "$release" > "$out/release"
printf '%s\n%s\n' "$package" "$(basename "$kernel_deb")" > "$stamp"
log "kernel $release ($(basename "$kernel_deb")), busybox and modules.dep ready in $out ($((SECONDS - start)) s)"
