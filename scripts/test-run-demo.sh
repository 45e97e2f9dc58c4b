#!/usr/bin/env bash
# The technician's test run against the simulated EMA, both on vcan0 (run it through
# scripts/vcan/with_vcan.sh, which provides vcan0 on any host):
#   scripts/test-run-demo.sh BUILD_DIR|EMADIAG_BINARY OUT_DIR
#   (the installed package: /usr/libexec/emadiag/test-run-demo.sh /usr/bin/emadiag OUT_DIR)
# Starts `emadiag ema-sim` (case A: on the ground, typical sensor noise) and runs
# `emadiag test-run` against it; the database and the raw logs go to OUT_DIR. The simulated EMA
# leaves 3 s after the tool's last frame (--idle-exit), however the test run ended, so nothing
# waits for a sequence that never comes. Exits with test-run's status (0 = SERVICEABLE).
set -u
EMADIAG="$1/src/emadiag"
[ -f "$1" ] && EMADIAG="$1"
OUT="$2"
mkdir -p "$OUT"
"$EMADIAG" ema-sim --bus socketcan:vcan0 --case A --noise typical --seed 5 --time-scale "${EMADIAG_VCAN_TIME_SCALE:-2}" \
    --idle-exit 3 > "$OUT/ema-sim.out" 2>&1 &
EMA=$!
for _ in $(seq 200); do grep -q "ema-sim on" "$OUT/ema-sim.out" 2>/dev/null && break; sleep 0.05; done
"$EMADIAG" test-run --bus socketcan:vcan0 --tail N123EM --phase pre-flight --db "$OUT/maintenance.db" --out-dir "$OUT/test-runs" \
    --position LH-ELEV --cycles 18342 --hours 31207.5 --operator EMA-AIR --technician "J. Smith" --certificate B1-4471
RC=$?
wait "$EMA"
echo "-- the simulated EMA's log --"
cat "$OUT/ema-sim.out"
if [ "$RC" -ne 0 ]; then
    echo "test-run-demo: emadiag test-run exited with status $RC (2 = NO_TEST, 3 = UNSERVICEABLE, 4 = INCONCLUSIVE, 1 = error); see above" >&2
fi
exit $RC
