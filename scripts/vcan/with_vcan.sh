#!/bin/bash
# Runs a command on a host where vcan0 exists.
#   scripts/vcan/with_vcan.sh WORK_DIR COMMAND [ARG...]
# When the host kernel has vcan (vcan0 exists, or can be created), COMMAND runs directly. Otherwise
# the script boots user-mode Linux (linux.uml, Debian package user-mode-linux) with the host's /
# as root (hostfs), loads can, can-raw, can-dev and vcan, creates vcan0, runs COMMAND inside
# (same working directory, HOME and TMPDIR on a guest tmpfs in WORK_DIR/scratch) and powers off.
# The guest's exit status does not come back from linux.uml, so the guest writes COMMAND's output
# and status into WORK_DIR; this script prints them and exits with COMMAND's status.
# EMADIAG_VCAN_VM=qemu: boot a full-system QEMU VM instead of user-mode Linux
# (scripts/vcan/with_vcan_vm.sh: what an AddressSanitizer build needs, which UML's 512 GB address
# space cannot hold); uml (default) as described here.
# Environment: EMADIAG_VCAN_TIME_SCALE (telemetry pacing, default 2, what vcan in the guest carries
#              without loss), EMADIAG_UML_MEM (guest memory, default 512M),
#              EMADIAG_UML_TIMEOUT_S (default 600), EMADIAG_UML_PRIORITY (the guest's host
#              scheduling: `rt` (default) SCHED_FIFO 10 where permitted, else nice -10; `nice`
#              nice -10; `normal` unchanged).
# Priority: the guest has one virtual CPU and schedules its own threads, so the tool's SCHED_FIFO
# heartbeat thread outranks the other threads inside the guest, but against the host's load the
# whole guest is ordinary host tasks, and every guest system call is several host context switches.
# On a busy host each of those waits for a time slice, and the guest stalls for 100 ms and more:
# the EMA's watchdog then sees the heartbeat late although the tool sent it on time in guest time.
# On a real host the heartbeat thread's own real-time priority does that job; here the guest as a
# whole runs at a real-time host priority, the closest equivalent. It sleeps when idle, and the
# kernel's real-time throttling (95 % per second) keeps the host responsive. The benchmark
# (bench/vcan_session_bench.sh) reports the gaps with each setting.
set -u
if [ $# -lt 2 ]; then
    echo "usage: $0 WORK_DIR COMMAND [ARG...]" >&2
    exit 2
fi
mkdir -p "$1" || exit 2
WORK=$(cd "$1" && pwd)
shift
IFACE=vcan0

host_has_vcan() {
    [ -d /sys/class/net/$IFACE ] && return 0
    # Try to create it (root with the vcan module available).
    { modprobe vcan && ip link add dev $IFACE type vcan && ip link set $IFACE up; } >/dev/null 2>&1
}

if host_has_vcan; then
    echo "with_vcan: host kernel has $IFACE; running directly"
    ip link set $IFACE up >/dev/null 2>&1 || true
    "$@"
    exit $?
fi

case "${EMADIAG_VCAN_VM:-uml}" in
    uml) ;;
    qemu) exec "$(dirname "$0")/with_vcan_vm.sh" "$WORK" "$@" ;;
    *) echo "$0: EMADIAG_VCAN_VM must be uml or qemu" >&2; exit 2 ;;
esac

UML=$(command -v linux.uml || true)
if [ -z "$UML" ]; then
    echo "$0: the host has no vcan and linux.uml is not installed (Debian package user-mode-linux)" >&2
    exit 2
fi
rm -rf "$WORK/scratch" "$WORK/command.log" "$WORK/command.status"
# The command, quoted word by word, for the guest's shell.
CMD=$(printf '%q ' "$@")
INIT="$WORK/init.sh"
cat > "$INIT" <<INIT_EOF
#!/bin/bash
# PID 1 of the user-mode Linux guest (written by with_vcan.sh).
export PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
# Scratch space is a tmpfs of its own inside the work folder, not over /tmp: the work folder may
# itself live under the host's /tmp, which the guest sees through hostfs.
mkdir -p "$WORK/scratch"
export HOME="$WORK/scratch" TMPDIR="$WORK/scratch" EMADIAG_VCAN_TIME_SCALE=${EMADIAG_VCAN_TIME_SCALE:-2}
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t tmpfs -o size=256m tmpfs "$WORK/scratch"
{
    echo "guest kernel \$(uname -r), \$(nproc) cpu"
    M=/usr/lib/uml/modules/\$(uname -r)/kernel
    for m in net/can/can.ko net/can/can-raw.ko drivers/net/can/dev/can-dev.ko drivers/net/can/vcan.ko; do
        insmod "\$M/\$m" || echo "insmod \$m failed"
    done
    ip link add dev $IFACE type vcan && ip link set $IFACE up && ip -brief link show $IFACE
} > "$WORK/guest-setup.log" 2>&1
cd $(printf '%q' "$PWD") && $CMD > "$WORK/command.log" 2>&1
echo \$? > "$WORK/command.status"
sync
poweroff -f
INIT_EOF
chmod +x "$INIT"
echo "with_vcan: host has no $IFACE; booting user-mode Linux ($UML) to run: $*"
# shellcheck source=guest_priority.sh
. "$(dirname "$0")/guest_priority.sh"
guest_priority "${EMADIAG_UML_PRIORITY:-rt}" || { echo "$0: EMADIAG_UML_PRIORITY must be rt, nice or normal" >&2; exit 2; }
echo "with_vcan: guest host priority: ${PRIO[*]:-normal}"
"${PRIO[@]}" timeout "${EMADIAG_UML_TIMEOUT_S:-600}" "$UML" mem="${EMADIAG_UML_MEM:-512M}" root=/dev/root rootfstype=hostfs rootflags=/ rw \
    init="$INIT" con=null con0=fd:0,fd:1 </dev/null >"$WORK/uml-console.log" 2>&1
UML_RC=$?
cat "$WORK/guest-setup.log" 2>/dev/null
if [ "$UML_RC" -eq 124 ]; then
    echo "with_vcan: stopped: user-mode Linux did not finish within ${EMADIAG_UML_TIMEOUT_S:-600} s (EMADIAG_UML_TIMEOUT_S) running: $*" >&2
fi
if [ ! -f "$WORK/command.status" ]; then
    echo "with_vcan: the guest wrote no status (linux.uml exit $UML_RC); console:" >&2
    tail -n 40 "$WORK/uml-console.log" >&2
    cat "$WORK/command.log" 2>/dev/null
    exit 1
fi
cat "$WORK/command.log"
exit "$(cat "$WORK/command.status")"
