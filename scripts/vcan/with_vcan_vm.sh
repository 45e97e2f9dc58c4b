#!/bin/bash
# Runs a command on vcan0 inside a full-system QEMU virtual machine (TCG: no /dev/kvm needed).
#   scripts/vcan/with_vcan_vm.sh WORK_DIR COMMAND [ARG...]
# scripts/vcan/with_vcan.sh calls it when the host kernel has no vcan and EMADIAG_VCAN_VM=qemu; it
# can also be called on its own. Why a VM and not user-mode Linux: the Debian UML kernel gives a
# process 512 GB of address space (3-level page tables), while AddressSanitizer's x86-64 runtime
# has a fixed shadow layout up to 0x10007fff7fff and its allocator at 0x600000000000, so an ASan
# binary aborts in UML ("Shadow memory range interleaves with an existing memory mapping"). A
# QEMU x86-64 guest has the real 4-level, 128 TB address space, and loads the real vcan module.
# The guest: the Debian kernel of the host (/boot/vmlinuz-*, package linux-image-amd64) with its
# /lib/modules, a busybox initramfs (busybox-static) built here that loads virtio and 9p, mounts
# the host's / read-only over virtio-9p, and the command's working directory and WORK_DIR writable
# (both at their host paths), then switch_root's into the host's root. There, as with_vcan.sh does
# in UML, it loads can, can-raw, can-dev and vcan, creates vcan0, runs COMMAND (same working
# directory, HOME and TMPDIR on a guest tmpfs in WORK_DIR/scratch; /tmp, /run, /dev/shm are guest
# tmpfs) and powers off. COMMAND's output and exit status come back through WORK_DIR; this script
# prints them and exits with COMMAND's status.
# Environment: EMADIAG_VCAN_TIME_SCALE (telemetry pacing, default 2, passed to the guest as in
#              with_vcan.sh), EMADIAG_VM_MEM (guest memory, default 2048M), EMADIAG_VM_CPUS
#              (virtual CPUs, default 2, multi-threaded TCG), EMADIAG_VM_TIMEOUT_S (default 1800),
#              EMADIAG_VM_KERNEL (kernel image, default the newest /boot/vmlinuz-* that has
#              /lib/modules), EMADIAG_VM_PRIORITY (rt|nice|normal, default nice), EMADIAG_VM_NICE (a host nice value instead),
#              EMADIAG_VM_PRELOAD (files, with the shared libraries they load, read into the guest's
#              page cache before COMMAND: see below), and, passed into the guest when set (the rest of
#              the host environment is not):
#              ASAN_OPTIONS, UBSAN_OPTIONS, LSAN_OPTIONS.
set -u
if [ $# -lt 2 ]; then
    echo "usage: $0 WORK_DIR COMMAND [ARG...]" >&2
    exit 2
fi
mkdir -p "$1" || exit 2
WORK=$(cd "$1" && pwd)
shift
IFACE=vcan0
QEMU=$(command -v qemu-system-x86_64 || true)
BUSYBOX=$(command -v busybox || true)
if [ -z "$QEMU" ]; then
    echo "$0: qemu-system-x86_64 is not installed (Debian package qemu-system-x86)" >&2
    exit 2
fi
if [ -z "$BUSYBOX" ] || ! "$BUSYBOX" cpio --help >/dev/null 2>&1 || ldd "$BUSYBOX" >/dev/null 2>&1; then
    echo "$0: a static busybox with cpio is needed for the guest's initramfs (Debian package busybox-static)" >&2
    exit 2
fi
KERNEL=${EMADIAG_VM_KERNEL:-}
if [ -z "$KERNEL" ]; then
    # shellcheck disable=SC2045  # ls -v: version order, the newest last (the names have no spaces)
    for k in $(ls -v /boot/vmlinuz-* 2>/dev/null); do
        [ -d "/lib/modules/${k#/boot/vmlinuz-}" ] && KERNEL=$k
    done
fi
KVER=${KERNEL#/boot/vmlinuz-}
MODDIR=/lib/modules/$KVER
if [ -z "$KERNEL" ] || [ ! -r "$KERNEL" ] || [ ! -f "$MODDIR/modules.dep" ]; then
    echo "$0: no guest kernel: need /boot/vmlinuz-VERSION and /lib/modules/VERSION (Debian package linux-image-amd64)" >&2
    exit 2
fi
for m in kernel/drivers/net/can/vcan.ko kernel/net/can/can-raw.ko kernel/fs/9p/9p.ko kernel/net/9p/9pnet_virtio.ko; do
    if [ ! -f "$MODDIR/$m" ]; then
        echo "$0: kernel $KVER has no $m" >&2
        exit 2
    fi
done
# Boot the uncompressed kernel through its PVH entry (CONFIG_PVH, an ELF note QEMU finds): the
# bzImage's own XZ decompression under TCG took 23 s of a 77 s run on the loaded host, this 2 s.
# Kept in WORK_DIR for the next run; the bzImage when the extraction fails (python3's lzma).
BOOT=$KERNEL
VMLINUX="$WORK/vmlinux-$KVER"
if [ ! -s "$VMLINUX" ] || [ "$KERNEL" -nt "$VMLINUX" ]; then
    python3 - "$KERNEL" "$VMLINUX.tmp" <<'PY_EOF' && mv "$VMLINUX.tmp" "$VMLINUX" || rm -f "$VMLINUX.tmp"
import lzma, sys
data = open(sys.argv[1], "rb").read()
at = data.find(b"\xfd7zXZ\x00")
if at < 0:
    sys.exit(1)
out = lzma.LZMADecompressor(format=lzma.FORMAT_XZ).decompress(data[at:])
if out[:4] != b"\x7fELF" or b"Xen\x00" not in out:
    sys.exit(1)
open(sys.argv[2], "wb").write(out)
PY_EOF
fi
[ -s "$VMLINUX" ] && BOOT=$VMLINUX
rm -rf "$WORK/scratch" "$WORK/command.log" "$WORK/command.status" "$WORK/guest-setup.log" "$WORK/initramfs"

# ---- The initramfs: busybox, the virtio/9p modules in dependency order, and /init. ----
ORDER=()
add_module() {  # $1: path relative to $MODDIR; its dependencies first (modules.dep).
    local m=$1 d
    for d in "${ORDER[@]}"; do [ "$d" = "$m" ] && return; done
    for d in $(sed -n "s|^$m: *||p" "$MODDIR/modules.dep"); do add_module "$d"; done
    ORDER+=("$m")
}
for m in kernel/drivers/virtio/virtio_pci.ko kernel/net/9p/9pnet_virtio.ko kernel/fs/9p/9p.ko; do add_module "$m"; done
IRD="$WORK/initramfs"
mkdir -p "$IRD/bin" "$IRD/proc" "$IRD/sys" "$IRD/dev" "$IRD/newroot" "$IRD/modules"
cp "$BUSYBOX" "$IRD/bin/busybox"
for m in "${ORDER[@]}"; do cp "$MODDIR/$m" "$IRD/modules/"; done
# 9p shares: the host root read-only (cache=loose: nothing changes it while the guest runs), and
# the working directory and WORK_DIR writable at their host paths.
# One share when one folder holds the other (a share mounted inside another would be hidden by it).
case "$PWD/" in
    "$WORK/"*) RW=("$WORK") ;;
    *) case "$WORK/" in "$PWD/"*) RW=("$PWD") ;; *) RW=("$WORK" "$PWD") ;; esac ;;
esac
SHARES=(-virtfs "local,path=/,mount_tag=hostroot,security_model=none,readonly=on,multidevs=remap")
MOUNTS=""
i=0
for p in "${RW[@]}"; do
    SHARES+=(-virtfs "local,path=$p,mount_tag=rw$i,security_model=none,multidevs=remap")
    MOUNTS+="mkdir -p $(printf '%q' "/newroot$p") 2>/dev/null; mount -t 9p -o trans=virtio,version=9p2000.L,msize=512000,cache=mmap rw$i $(printf '%q' "/newroot$p") || fail 'cannot mount $p'"$'\n'
    i=$((i + 1))
done
{
    echo '#!/bin/busybox sh'
    echo '# PID 1 of the initramfs (written by with_vcan_vm.sh).'
    echo '/bin/busybox --install -s /bin'
    echo 'export PATH=/bin'
    echo 'fail() { echo "with_vcan_vm guest: $*"; poweroff -f; }'
    echo 'mount -t proc proc /proc; mount -t sysfs sysfs /sys; mount -t devtmpfs devtmpfs /dev'
    for m in "${ORDER[@]}"; do echo "insmod /modules/${m##*/} || fail 'insmod ${m##*/} failed'"; done
    echo 'mount -t 9p -o trans=virtio,version=9p2000.L,msize=512000,cache=loose,ro hostroot /newroot || fail "cannot mount the host root"'
    # Guest tmpfs on /tmp and /run before the writable shares, which may live under them.
    echo 'for d in /newroot/tmp /newroot/run; do mount -t tmpfs -o size=512m tmpfs $d || fail "cannot mount $d"; done'
    printf '%s' "$MOUNTS"
    echo 'mkdir -p /dev/shm; mount --move /dev /newroot/dev; umount /proc /sys'
    echo "exec switch_root /newroot $(printf '%q' "$WORK/init.sh")"
} > "$IRD/init"
chmod +x "$IRD/init"
(cd "$IRD" && find . | "$BUSYBOX" cpio -o -H newc 2>/dev/null | gzip -1) > "$WORK/initramfs.cpio.gz" || exit 2
rm -rf "$IRD"

# ---- PID 1 in the host's root, the same steps as with_vcan.sh's guest. ----
CMD=$(printf '%q ' "$@")
GUEST_ENV=""
for v in ASAN_OPTIONS UBSAN_OPTIONS LSAN_OPTIONS; do
    [ -n "${!v+set}" ] && GUEST_ENV+="export $v=$(printf '%q' "${!v}")"$'\n'
done
# Files to read into the guest's page cache before COMMAND (EMADIAG_VM_PRELOAD), with the shared
# libraries they load. Under TCG a page of a 48 MB ASan binary first touched during a test is a
# read over 9p; the faulting process holds its mm's lock meanwhile, and its heartbeat thread, due
# every 20 ms, stalled with it: the EMA saw gaps of 124 and 172 ms right after `record` started.
PRELOAD=""
for f in ${EMADIAG_VM_PRELOAD:-}; do
    [ -f "$f" ] || { echo "$0: EMADIAG_VM_PRELOAD: no file $f" >&2; exit 2; }
    PRELOAD+=" $(printf '%q' "$(realpath "$f")")"
    for lib in $(ldd "$f" 2>/dev/null | awk '$2 == "=>" && $3 ~ /^\// {print $3}'); do PRELOAD+=" $(printf '%q' "$lib")"; done
done
INIT="$WORK/init.sh"
cat > "$INIT" <<INIT_EOF
#!/bin/bash
# PID 1 of the QEMU guest after switch_root into the host's root (written by with_vcan_vm.sh).
export PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mkdir -p "$WORK/scratch"
for d in /dev/shm "$WORK/scratch"; do mount -t tmpfs -o size=512m tmpfs "\$d"; done
export HOME="$WORK/scratch" TMPDIR="$WORK/scratch" EMADIAG_VCAN_TIME_SCALE=${EMADIAG_VCAN_TIME_SCALE:-2}
$GUEST_ENV{
    echo "guest kernel \$(uname -r), \$(nproc) cpu, clocksource \$(cat /sys/devices/system/clocksource/clocksource0/current_clocksource), up \$(cut -d' ' -f1 /proc/uptime) s"
    for m in can can-raw can-dev vcan; do
        modprobe "\$m" || echo "modprobe \$m failed"
    done
    ip link add dev $IFACE type vcan && ip link set $IFACE up && ip -brief link show $IFACE
    [ -z "$PRELOAD" ] || { cat $PRELOAD > /dev/null && echo "preloaded into the page cache:$PRELOAD"; }
} > "$WORK/guest-setup.log" 2>&1
cd $(printf '%q' "$PWD") && $CMD > "$WORK/command.log" 2>&1
echo \$? > "$WORK/command.status"
sync
poweroff -f
INIT_EOF
chmod +x "$INIT"

# Host priority of the VM, as with_vcan.sh gives the UML guest (EMADIAG_VM_PRIORITY=rt|nice|normal):
# the guest's 100 ms watchdog and 20 ms heartbeat are real time inside an emulated machine, so a busy
# host must not take its CPUs away. rt: SCHED_FIFO 10 where permitted, else nice -10. EMADIAG_VM_NICE
# (a nice value) keeps working for a host that wants the VM below its other work.
# shellcheck source=guest_priority.sh
. "$(dirname "$0")/guest_priority.sh"
if [ -n "${EMADIAG_VM_NICE:-}" ]; then PRIO=(nice -n "$EMADIAG_VM_NICE")
else
    # Default nice, not rt: under SCHED_FIFO the two vCPU threads of multi-threaded TCG spin on both
    # host cores and QEMU's own I/O thread never runs (a run on 2026-11-25 printed not one console line
    # in 14 minutes).
    guest_priority "${EMADIAG_VM_PRIORITY:-nice}" || { echo "$0: EMADIAG_VM_PRIORITY must be rt, nice or normal" >&2; exit 2; }
fi
echo "with_vcan_vm: VM host priority: ${PRIO[*]:-normal}"
echo "with_vcan_vm: booting a QEMU VM (TCG, kernel $KVER from ${BOOT##*/}, ${EMADIAG_VM_CPUS:-2} cpu, ${EMADIAG_VM_MEM:-2048M}) to run: $*"
START=$(date +%s.%N)
"${PRIO[@]}" timeout "${EMADIAG_VM_TIMEOUT_S:-1800}" "$QEMU" -nodefaults -no-user-config -display none -no-reboot \
    -machine pc -accel tcg,thread=multi -cpu max -smp "${EMADIAG_VM_CPUS:-2}" -m "${EMADIAG_VM_MEM:-2048M}" \
    -kernel "$BOOT" -initrd "$WORK/initramfs.cpio.gz" \
    -append "console=ttyS0 quiet panic=-1 mitigations=off no_timer_check tsc=reliable ${EMADIAG_VM_APPEND:-}" \
    "${SHARES[@]}" -serial "file:$WORK/vm-console.log" </dev/null >"$WORK/qemu.log" 2>&1
VM_RC=$?
awk -v s="$START" -v e="$(date +%s.%N)" 'BEGIN { printf "with_vcan_vm: the VM ran %.1f s\n", e - s }'
cat "$WORK/guest-setup.log" 2>/dev/null
if [ "$VM_RC" -eq 124 ]; then
    echo "with_vcan_vm: stopped: the VM did not finish within ${EMADIAG_VM_TIMEOUT_S:-1800} s (EMADIAG_VM_TIMEOUT_S) running: $*" >&2
fi
if [ ! -f "$WORK/command.status" ]; then
    echo "with_vcan_vm: the guest wrote no status (qemu exit $VM_RC); console and qemu output:" >&2
    tail -n 40 "$WORK/vm-console.log" "$WORK/qemu.log" >&2
    cat "$WORK/command.log" 2>/dev/null
    exit 1
fi
cat "$WORK/command.log"
exit "$(cat "$WORK/command.status")"
