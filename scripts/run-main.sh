#!/usr/bin/env bash
# README command (a): set up, build, and run the main job.
# EMADIAG_MAIN_QUICK=1 runs the same steps with smaller counts (CI runs it that way).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh release
mkdir -p out
echo "== emadiag simulate: the reference EMA, DYN sequence, case B (in flight), datasheet health =="
./build/src/emadiag simulate --case B --sequence dyn --out out/reference_dyn_B.csv
echo
echo "== emadiag test-run: the technician's test run on the ramp, against the simulated EMA on vcan0 =="
echo "   (scripts/vcan/with_vcan.sh boots user-mode Linux when this kernel has no vcan)"
rm -rf out/test-run
if ! scripts/vcan/with_vcan.sh out/test-run/uml scripts/test-run-demo.sh "$PWD/build" "$PWD/out/test-run"; then
    echo "run-main: the technician's test run did not end SERVICEABLE (see its output above); the main job stops here" >&2
    exit 1
fi
echo
echo "== emadiag trend: a reliability engineer's report for one tail number, one trend per position =="
SESSIONS=12
[ "${EMADIAG_MAIN_QUICK:-0}" = 1 ] && SESSIONS=6
echo "   ($SESSIONS monthly pre-flight sessions per elevator actuator; LH-ELEV's friction rises: its true FDJ crosses"
echo "    the 0.096 N m limit at day 400, 70 days after the last session, FSJ 0.144 N m at day 1200; RH-ELEV's"
echo "    rises a quarter as fast: FDJ at day 1600. Each position is trended on its own, never pooled)"
rm -rf out/trend && mkdir -p out/trend
./build/src/emadiag history-sim --db out/trend/maintenance.db --tail N456EM --position LH-ELEV --sessions "$SESSIONS" --days-between 30 \
    --fdj-rate-per-100d 0.004 --fsj-rate-per-100d 0.002 --seed 3
./build/src/emadiag history-sim --db out/trend/maintenance.db --tail N456EM --position RH-ELEV --serial 2002 --sessions "$SESSIONS" \
    --days-between 30 --fdj-rate-per-100d 0.001 --fsj-rate-per-100d 0.0005 --seed 4
./build/src/emadiag trend --db out/trend/maintenance.db --tail N456EM
echo
echo "== emadiag report: the maintenance record of N456EM per position and serial, and its HTML report =="
./build/src/emadiag report --db out/trend/maintenance.db --tail N456EM --format text
./build/src/emadiag report --db out/trend/maintenance.db --tail N456EM --format html --out out/trend/N456EM.html
echo "wrote out/trend/N456EM.html ($(wc -c < out/trend/N456EM.html) bytes; a section per position and per serial; one self-contained file, open it in any browser)"
echo
echo "== emadiag fleet: every tail and position, most urgent first =="
./build/src/emadiag history-sim --db out/trend/maintenance.db --tail N789EM --position LH-ELEV --serial 3003 --sessions "$SESSIONS" \
    --days-between 30 --fdj-rate-per-100d 0.002 --fsj-rate-per-100d 0.001 --seed 5
./build/src/emadiag fleet --db out/trend/maintenance.db
echo
echo "== emadiag discover: closing the loop on a run with an effect the model was never told about =="
echo "   (case B DYN, typical noise, viscous friction 2e-5 N m s/rad that the datasheet model lacks)"
./build/src/emadiag simulate --case B --sequence dyn --noise typical --seed 4 --effect viscous=2e-5 --out out/viscous_dyn_B.csv
./build/src/emadiag discover out/viscous_dyn_B.csv --out-model out/viscous_dyn_B.model.json
