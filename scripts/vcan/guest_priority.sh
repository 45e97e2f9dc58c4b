# Sourced by with_vcan.sh (UML) and with_vcan_vm.sh (QEMU): sets the array PRIO to the command prefix
# that runs a vcan guest at the host priority asked for, rt|nice|normal (the first argument).
# rt: SCHED_FIFO 10 where permitted, else nice -10; nice: nice -10 where permitted. The guest's 100 ms
# watchdog and 20 ms heartbeat are real time inside it, so a busy host must not take its CPU away.
# (nice -n -10 without the right prints a warning and still runs the command: hence the output test.)
guest_priority() {
    PRIO=()
    case "$1" in
        rt)
            if chrt -f 10 true 2>/dev/null; then PRIO=(chrt -f 10)
            elif [ -z "$(nice -n -10 true 2>&1)" ]; then PRIO=(nice -n -10); fi ;;
        nice) if [ -z "$(nice -n -10 true 2>&1)" ]; then PRIO=(nice -n -10); fi ;;
        normal) ;;
        *) return 1 ;;
    esac
}
