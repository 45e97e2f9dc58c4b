#!/usr/bin/env bash
# The technician's test run over vcan, measured: a full DYN + BRK session of `emadiag test-run`
# against `emadiag ema-sim`, at each telemetry time scale, with N CPU hogs on the host. Runs
# inside user-mode Linux when the kernel has no vcan (scripts/vcan/with_vcan.sh).
#   bench/vcan_session_bench.sh BUILD_DIR [--hogs N] [--scales "1 2"] [--repeats R] [--tool EMADIAG]
# Prints per run: the heartbeat gaps the EMA saw in GROUND_TEST (p50, p99, max; its watchdog is
# 100 ms), the frames per second the tool handled (lines of its raw logs over its wall time), the
# tool's CPU time per frame (user + system of the test-run process), and the verdict.
# --tool runs another emadiag binary as the tool (for example one built from an older commit);
# the EMA is always BUILD_DIR's, since the gap figures come from its watchdog.
set -u
if [ "${1:-}" = "--inner" ]; then
    # Inside the guest (or directly on a host with vcan): one session per scale and repeat.
    shift
    EMA_BIN=$1 TOOL_BIN=$2 OUT=$3 SCALES=$4 REPEATS=$5
    for scale in $SCALES; do
        for rep in $(seq "$REPEATS"); do
            d="$OUT/scale$scale-$rep"
            rm -rf "$d" && mkdir -p "$d"
            "$EMA_BIN" ema-sim --bus socketcan:vcan0 --case A --noise typical --seed 5 --time-scale "$scale" --idle-exit 3 \
                > "$d/ema.out" 2>&1 &
            ema=$!
            for _ in $(seq 200); do grep -q "ema-sim on" "$d/ema.out" 2>/dev/null && break; sleep 0.05; done
            TIMEFORMAT='%R %U %S'
            { time "$TOOL_BIN" test-run --bus socketcan:vcan0 --tail N123EM --db "$d/m.db" --out-dir "$d/logs" \
                > "$d/tool.out" 2>&1; } 2> "$d/time.txt"
            echo "rc $?" >> "$d/time.txt"
            wait "$ema"
            frames=$(cat "$d"/logs/*.log 2>/dev/null | wc -l)
            read -r wall user sys < "$d/time.txt"
            gaps=$(grep -o "heartbeat gaps seen in GROUND_TEST: .*" "$d/ema.out" | head -1)
            verdict=$(grep -o "VERDICT: [A-Z_]*" "$d/tool.out" | head -1)
            lost=$(grep -c "heartbeat lost" "$d/ema.out")
            awk -v s="$scale" -v r="$rep" -v f="$frames" -v w="$wall" -v u="$user" -v y="$sys" -v g="$gaps" -v v="$verdict" -v l="$lost" 'BEGIN {
                n = split(g, a, /[ ,]+/); p50 = "-"; p99 = "-"; mx = "-";
                for (i = 1; i <= n; i++) { if (a[i] == "p50") p50 = a[i+1]; if (a[i] == "p99") p99 = a[i+1]; if (a[i] == "max") mx = a[i+1]; }
                printf "scale %s run %s: heartbeat gap p50 %s ms, p99 %s ms, max %s ms; %d frames in %.2f s = %.0f frames/s; tool CPU %.1f us/frame; %s; watchdog aborts %d\n",
                       s, r, p50, p99, mx, f, w, (w > 0 ? f / w : 0), (f > 0 ? 1e6 * (u + y) / f : 0), (v == "" ? "no verdict" : v), l }'
        done
    done
    exit 0
fi
if [ $# -lt 1 ] || [ ! -x "$1/src/emadiag" ]; then
    echo "usage: $0 BUILD_DIR [--hogs N] [--scales \"1 2\"] [--repeats R] [--tool EMADIAG]" >&2
    exit 2
fi
BUILD=$(cd "$1" && pwd)
shift
HOGS=0 SCALES="1 2" REPEATS=3 TOOL="$BUILD/src/emadiag"
while [ $# -gt 0 ]; do
    case "$1" in
        --hogs) HOGS=$2; shift 2 ;;
        --scales) SCALES=$2; shift 2 ;;
        --repeats) REPEATS=$2; shift 2 ;;
        --tool) TOOL=$(readlink -f "$2"); shift 2 ;;
        *) echo "$0: unknown option $1" >&2; exit 2 ;;
    esac
done
HERE=$(cd "$(dirname "$0")" && pwd)
OUT="$BUILD/vcan-session-bench"
rm -rf "$OUT" && mkdir -p "$OUT"
HOG_PIDS=()
stop_hogs() { for p in "${HOG_PIDS[@]}"; do kill "$p" 2>/dev/null; done; }
trap stop_hogs EXIT
for _ in $(seq "$HOGS"); do (while :; do :; done) & HOG_PIDS+=($!); done
echo "vcan_session_bench: $(nproc) host cpus, $HOGS CPU hogs on the host, time scales $SCALES, $REPEATS repeats; tool $TOOL"
"$HERE/../scripts/vcan/with_vcan.sh" "$OUT/uml" "$HERE/vcan_session_bench.sh" --inner "$BUILD/src/emadiag" "$TOOL" "$OUT" "$SCALES" "$REPEATS"
STATUS=$?
stop_hogs
exit $STATUS
