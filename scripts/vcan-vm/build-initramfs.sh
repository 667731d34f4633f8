#!/usr/bin/env bash
# build-initramfs.sh OUT.cpio.gz PAYLOAD_DIR
#
# Builds a gzip'd newc initramfs that boots the Debian kernel (see run-vm.sh),
# loads the CAN modules, creates and raises vcan0 and runs PAYLOAD_DIR/run
# (PAYLOAD_DIR is copied to /payload). See README.md.
#
# Idempotent: the kernel .deb, the extracted vmlinuz + modules and the base
# root file system are cached under $VCAN_VM_CACHE (default
# <repo>/target/vcan-vm). Only the payload is added on every call.
#
# Environment:
#   VCAN_VM_CACHE       cache folder (default: <repo>/target/vcan-vm)
#   VCAN_VM_KERNEL_PKG  kernel package (default: what linux-image-amd64 depends on)
#   VCAN_VM_MODULES     modules to load (default: "can-dev vcan can can-raw");
#                       their dependencies are added, the order is resolved
#   VCAN_VM_CAN_UTILS   1 (default): add can-utils (cansend, candump, canplayer,
#                       cangen, ...) and the glibc loader/libc they need; 0: don't
#   VCAN_VM_PVH         1 (default): print the uncompressed ELF vmlinux (PVH boot,
#                       ~2x faster under TCG) when there is one; 0: the bzImage
#
# Prints the path of the kernel image to boot as its last line of stdout.
set -euo pipefail

die() { echo "build-initramfs.sh: $*" >&2; exit 1; }
log() { echo "build-initramfs.sh: $*" >&2; }

[ $# -eq 2 ] || die "usage: build-initramfs.sh OUT.cpio.gz PAYLOAD_DIR"
OUT=$1
PAYLOAD=$2
[ -d "$PAYLOAD" ] || die "payload dir '$PAYLOAD' does not exist"
[ -f "$PAYLOAD/run" ] || die "payload dir '$PAYLOAD' has no 'run' entry script"

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
REPO=$(cd "$HERE/../.." && pwd)
CACHE=${VCAN_VM_CACHE:-$REPO/target/vcan-vm}
MODULES=${VCAN_VM_MODULES:-can-dev vcan can can-raw}
CAN_UTILS=${VCAN_VM_CAN_UTILS:-1}
mkdir -p "$CACHE"
CACHE=$(cd "$CACHE" && pwd)

# Several tests may call us at once: serialise everything that touches the cache.
exec 9>"$CACHE/.lock"
flock 9

# --- host tools ------------------------------------------------------------
need_pkgs=()
command -v qemu-system-x86_64 >/dev/null 2>&1 || need_pkgs+=(qemu-system-x86)
dpkg-query -W -f='${Status}' busybox-static 2>/dev/null | grep -q 'install ok installed' \
    || need_pkgs+=(busybox-static)
if [ ${#need_pkgs[@]} -gt 0 ]; then
    log "installing ${need_pkgs[*]}"
    export DEBIAN_FRONTEND=noninteractive
    apt-get install -y --no-install-recommends "${need_pkgs[@]}" >&2 \
        || { apt-get update >&2 && apt-get install -y --no-install-recommends "${need_pkgs[@]}" >&2; }
fi
BUSYBOX=/bin/busybox
[ -x "$BUSYBOX" ] || die "$BUSYBOX missing after installing busybox-static"
if ldd "$BUSYBOX" >/dev/null 2>&1; then die "$BUSYBOX is not static (is 'busybox' installed instead of 'busybox-static'?)"; fi
for t in dpkg-deb apt-get gzip flock sha256sum; do
    command -v "$t" >/dev/null 2>&1 || die "'$t' not found"
done

# apt-get download writes into the cwd and complains (harmlessly) when _apt
# cannot write there; download into a world-writable scratch dir instead.
apt_download() { # PKG DESTDIR -> prints the .deb path
    local pkg=$1 dest=$2 tmp
    tmp=$(mktemp -d "$CACHE/dl.XXXXXX")
    chmod 777 "$tmp"
    (cd "$tmp" && apt-get download "$pkg" >&2) || { rm -rf "$tmp"; die "apt-get download $pkg failed"; }
    local deb
    deb=$(ls "$tmp"/*.deb)
    mkdir -p "$dest"
    mv "$deb" "$dest/"
    rm -rf "$tmp"
    echo "$dest/$(basename "$deb")"
}

# --- kernel package --------------------------------------------------------
KPKG=${VCAN_VM_KERNEL_PKG:-}
if [ -z "$KPKG" ]; then
    KPKG=$(apt-cache depends linux-image-amd64 2>/dev/null \
        | awk '$1 == "Depends:" && $2 ~ /^linux-image-/ { print $2; exit }') || true
    if [ -z "$KPKG" ] && [ -f "$CACHE/kernel-pkg" ]; then
        KPKG=$(cat "$CACHE/kernel-pkg")   # apt lists unavailable: use the last one
    fi
    [ -n "$KPKG" ] || die "cannot resolve the kernel package (apt-cache depends linux-image-amd64)"
fi
echo "$KPKG" > "$CACHE/kernel-pkg"

KDEB=$(ls "$CACHE/debs/${KPKG}_"*.deb 2>/dev/null | tail -n1 || true)
if [ -z "$KDEB" ]; then
    log "downloading $KPKG"
    KDEB=$(apt_download "$KPKG" "$CACHE/debs")
fi
KVER_DEB=$(dpkg-deb -f "$KDEB" Version)

# extract_vmlinux BZIMAGE OUT: find the compressed payload by its magic and
# decompress it (like the kernel's scripts/extract-vmlinux); OK if ELF.
extract_vmlinux() {
    local in=$1 out=$2 magic off dec
    for magic in xz zstd gzip; do
        case $magic in
            xz)   off=$(LC_ALL=C grep -abo $'\xfd7zXZ\x00' "$in" | head -n1 | cut -d: -f1); dec="xz -dc --single-stream" ;;
            zstd) off=$(LC_ALL=C grep -abo $'\x28\xb5\x2f\xfd' "$in" | head -n1 | cut -d: -f1); dec="zstd -q -dc" ;;
            gzip) off=$(LC_ALL=C grep -abo $'\x1f\x8b\x08' "$in" | head -n1 | cut -d: -f1); dec="gzip -dc" ;;
        esac
        [ -n "$off" ] || continue
        tail -c +$((off + 1)) "$in" | $dec > "$out.tmp" 2>/dev/null || true
        if [ "$(head -c 4 "$out.tmp" 2>/dev/null)" = $'\x7fELF' ]; then
            mv "$out.tmp" "$out"; return 0
        fi
        rm -f "$out.tmp"
    done
    return 1
}

# --- vmlinuz (once per kernel .deb) + modules (once per module list) ------
norm() { echo "${1//_/-}"; }   # module names: '-' and '_' are the same
KDIR=$CACHE/kernel/$KPKG
KSTAMP="$(basename "$KDEB") | pvh-v1"
MKEY=$(echo "$MODULES" | sha256sum | cut -c1-12)
MODDIR=$KDIR/modules-$MKEY
[ -f "$KDIR/stamp" ] && [ "$(cat "$KDIR/stamp")" = "$KSTAMP" ] || rm -rf "$KDIR"
if [ ! -f "$KDIR/stamp" ] || [ ! -f "$MODDIR/order" ]; then
    log "extracting $(basename "$KDEB")"
    X=$CACHE/kernel/.extract-$KPKG
    rm -rf "$X"
    mkdir -p "$X" "$KDIR"
    dpkg-deb -x "$KDEB" "$X"
    mdir=$(ls -d "$X"/lib/modules/*/ 2>/dev/null | head -n1) || true
    [ -n "$mdir" ] || mdir=$(ls -d "$X"/usr/lib/modules/*/ | head -n1)

    if [ ! -f "$KDIR/stamp" ]; then
        vmlinuz=$(ls "$X"/boot/vmlinuz-* | head -n1)
        cp "$vmlinuz" "$KDIR/vmlinuz"
        cp "$X"/boot/config-* "$KDIR/config" 2>/dev/null || true
        basename "$mdir" > "$KDIR/uname-r"
        # Debian's bzImage is XZ-compressed, and decompressing it under TCG
        # takes ~5 s. With CONFIG_PVH the uncompressed ELF vmlinux boots
        # directly (qemu -kernel vmlinux, PVH entry): decompress it once here.
        if grep -q '^CONFIG_PVH=y' "$KDIR/config" 2>/dev/null; then
            extract_vmlinux "$KDIR/vmlinuz" "$KDIR/vmlinux" \
                || log "note: could not extract an ELF vmlinux; booting the bzImage"
        fi
        echo "$KSTAMP" > "$KDIR/stamp"
    fi

    if [ ! -f "$MODDIR/order" ]; then
        rm -rf "$MODDIR"
        mkdir -p "$MODDIR"
        # index: normalised module name -> file
        declare -A modfile=()
        while IFS= read -r f; do
            b=$(basename "$f"); b=${b%%.ko*}
            modfile[$(norm "$b")]=$f
        done < <(find "$mdir" -name '*.ko' -o -name '*.ko.xz' -o -name '*.ko.zst' -o -name '*.ko.gz')

        # Decompress to a plain .ko: busybox insmod only reads uncompressed
        # modules (Debian 12's 6.1 modules are uncompressed anyway; later
        # Debian kernels ship .ko.xz). The appended signature survives.
        plain_ko() { # SRC DEST
            case "$1" in
                *.ko)     cp "$1" "$2" ;;
                *.ko.xz)  xz -dc "$1" > "$2" ;;
                *.ko.zst) zstd -q -dc "$1" > "$2" ;;
                *.ko.gz)  gzip -dc "$1" > "$2" ;;
            esac
        }
        declare -A seen=()
        order=()
        add_mod() { # NAME: depth-first, dependencies first
            local n f deps d
            n=$(norm "$1")
            [ -z "${seen[$n]:-}" ] || return 0
            seen[$n]=1
            f=${modfile[$n]:-}
            if [ -z "$f" ]; then
                grep -qE "(^|/)${n//-/[-_]}\.ko" "$mdir/modules.builtin" 2>/dev/null \
                    && { log "module $n is built in"; return 0; }
                rm -rf "$X" "$MODDIR"
                die "module $n not found in $KPKG"
            fi
            plain_ko "$f" "$MODDIR/$n.ko"
            deps=$(tr '\0' '\n' < "$MODDIR/$n.ko" | grep -a -m1 '^depends=' | cut -d= -f2) || true
            for d in ${deps//,/ }; do add_mod "$d"; done
            order+=("$n.ko")
        }
        for m in $MODULES; do add_mod "$m"; done
        printf '%s\n' "${order[@]}" > "$MODDIR/order.tmp"
        mv "$MODDIR/order.tmp" "$MODDIR/order"
    fi
    rm -rf "$X"
fi
ln -sfn "kernel/$KPKG/vmlinuz" "$CACHE/vmlinuz"
if [ -f "$KDIR/vmlinux" ]; then ln -sfn "kernel/$KPKG/vmlinux" "$CACHE/vmlinux"; else rm -f "$CACHE/vmlinux"; fi
echo "$KPKG $KVER_DEB $(cat "$KDIR/uname-r")" > "$CACHE/kernel-version"

# --- base root file system (cached; keyed by everything that goes in) -----
BASE_KEY=$( {
    echo "$KSTAMP"; echo "$MODDIR"; echo "can-utils=$CAN_UTILS"
    sha256sum "$HERE/init" "${BASH_SOURCE[0]}" "$BUSYBOX" | cut -d' ' -f1
} | sha256sum | cut -c1-16)
BASE=$CACHE/base-$BASE_KEY
if [ ! -f "$BASE/.done" ]; then
    log "building base root fs $BASE"
    # drop base trees unused for a week (old script versions, module sets)
    find "$CACHE" -maxdepth 1 -name 'base-*' -type d -mtime +7 -exec rm -rf {} + 2>/dev/null || true
    mkdir -p "$BASE"/{bin,sbin,usr/bin,usr/sbin,etc/vcan-vm,proc,sys,dev,tmp,run,payload,lib/modules/vcan-vm}
    cp "$BUSYBOX" "$BASE/bin/busybox"
    for a in $("$BUSYBOX" --list); do
        [ "$a" = busybox ] || ln -s busybox "$BASE/bin/$a"
    done
    cp "$MODDIR"/*.ko "$BASE/lib/modules/vcan-vm/" 2>/dev/null || true
    cp "$MODDIR/order" "$BASE/etc/vcan-vm/modules"
    cp "$HERE/init" "$BASE/init"
    chmod 755 "$BASE/init"
    # The kernel wants /dev/console before /init runs (devtmpfs comes later).
    # Needs root (mknod); without it the kernel falls back to no console for
    # /init's stdio, so be loud about it.
    mknod -m 600 "$BASE/dev/console" c 5 1 2>/dev/null \
        || log "warning: cannot mknod /dev/console (not root?)"
    mknod -m 666 "$BASE/dev/null" c 1 3 2>/dev/null || true

    if [ "$CAN_UTILS" = 1 ]; then
        CDEB=$(ls "$CACHE"/debs/can-utils_*.deb 2>/dev/null | tail -n1 || true)
        [ -n "$CDEB" ] || { log "downloading can-utils"; CDEB=$(apt_download can-utils "$CACHE/debs"); }
        CX=$(mktemp -d "$CACHE/can-utils.XXXXXX")
        dpkg-deb -x "$CDEB" "$CX"
        cp -a "$CX"/usr/bin/. "$BASE/usr/bin/"
        # their shared libraries (glibc) from this (Debian 12) host
        for b in "$CX"/usr/bin/*; do ldd "$b" 2>/dev/null || true; done \
            | awk '/=> \// { print $3 } /^\t\/[^ ]+ \(/ { print $1 }' | sort -u \
            | while read -r lib; do
                mkdir -p "$BASE$(dirname "$lib")"
                cp -L "$lib" "$BASE$lib"
            done
        rm -rf "$CX"
    fi
    touch "$BASE/.done"
fi
touch "$BASE"

# --- payload + archive ------------------------------------------------------
STAGE=$(mktemp -d "$CACHE/stage.XXXXXX")
trap 'rm -rf "$STAGE"' EXIT
cp -a "$BASE/." "$STAGE/"
rm -f "$STAGE/.done"
cp -a "$PAYLOAD/." "$STAGE/payload/"
mkdir -p "$(dirname "$OUT")"
OUT_ABS=$(cd "$(dirname "$OUT")" && pwd)/$(basename "$OUT")
(cd "$STAGE" && find . | LC_ALL=C sort | "$BUSYBOX" cpio -o -H newc -R 0:0 2>/dev/null | gzip -1 > "$OUT_ABS.tmp")
mv "$OUT_ABS.tmp" "$OUT_ABS"
log "wrote $OUT_ABS ($(stat -c %s "$OUT_ABS") bytes; kernel $(cat "$CACHE/kernel-version"))"
if [ "${VCAN_VM_PVH:-1}" = 1 ] && [ -f "$CACHE/vmlinux" ]; then
    echo "$CACHE/vmlinux"
else
    echo "$CACHE/vmlinuz"
fi
