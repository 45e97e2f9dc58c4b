#!/usr/bin/env python3
"""Writes the candump log (`candump -l` layout) of one EMA test session from a run CSV, frame for
frame as can_dbc/ema.dbc and can_dbc/ICD.md lay it out: EMA_Ident's 5 pages, TOOL_Command
ENTER_GROUND_TEST and START_SEQUENCE, EMA_Status every 5 samples (RUNNING, then DONE with
SamplesSent), TOOL_Heartbeat every 50 ms, and EMA_TelemetryA/B per sample with rolling counters and
the CRC-8 SAE J1850. The hostile probe (scripts/hostile/probe.sh) makes a real-looking session log
this way because recording one needs vcan (user-mode Linux), and then truncates it.

    make_candump.py RUN.csv OUT.log [--serial N] [--session N] [--no-done] [--abort]
"""
import argparse
import struct

ID_CMD, ID_HB, ID_STATUS, ID_IDENT, ID_TA, ID_TB = 0x010, 0x011, 0x020, 0x022, 0x100, 0x101


def crc8_j1850(data):
    crc = 0xFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc ^ 0xFF


def pack(fields, length=8):
    """fields: (start_bit, bit_length, raw) Intel (little-endian) signals."""
    word = 0
    for start, n, raw in fields:
        word |= (int(raw) & ((1 << n) - 1)) << start
    return list(word.to_bytes(8, "little")[:length])


def f32(x):
    return struct.unpack("<I", struct.pack("<f", x))[0]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv")
    ap.add_argument("out")
    ap.add_argument("--serial", type=int, default=1001)
    ap.add_argument("--session", type=int, default=1)
    ap.add_argument("--no-done", action="store_true", help="no final DONE status (a log cut before the end)")
    ap.add_argument("--abort", action="store_true", help="the final status is ABORTED")
    a = ap.parse_args()
    meta, rows = {}, []
    with open(a.csv) as f:
        for line in f:
            line = line.strip()
            if line.startswith("#"):
                k, _, v = line[1:].strip().partition("=")
                meta[k.strip()] = v.strip()
            elif line and not line[0].isalpha():
                rows.append([float(x) for x in line.split(",")[:5]])
    period = float(meta.get("sample_period_s", "0.0005"))
    seq = {"dyn": 1, "brk": 2}[meta.get("sequence", "dyn")]
    case = {"A": 0, "A-ext": 1, "B": 2}[meta.get("case", "A")]
    t = [1700000000.0]
    lines = []

    def emit(can_id, data, dt=0.0):
        t[0] += dt
        lines.append("(%.6f) vcan0 %03X#%s" % (t[0], can_id, "".join("%02X" % b for b in data)))

    status_counter = [0]

    def status(state, sent, mode=2):
        emit(ID_STATUS, pack([(0, 2, mode), (2, 1, 1), (3, 1, 1), (4, 2, state), (6, 2, seq if state else 0), (8, 2, case),
                              (12, 4, status_counter[0]), (16, 16, a.session), (32, 16, sent), (48, 8, 0)]), 0.0001)
        status_counter[0] = (status_counter[0] + 1) % 16

    emit(ID_CMD, pack([(0, 8, 5)], 4))
    emit(ID_IDENT, pack([(0, 8, 0), (8, 32, a.serial), (40, 8, 1), (48, 8, 2), (56, 8, 3)]), 0.001)
    emit(ID_IDENT, pack([(0, 8, 1), (8, 32, 42001), (40, 16, round(period / 1e-6))]), 0.001)
    emit(ID_IDENT, pack([(0, 8, 2), (8, 32, f32(float(meta["k_t_Nm_per_A"])))]), 0.001)
    emit(ID_IDENT, pack([(0, 8, 3), (8, 32, f32(float(meta["J_kgm2"])))]), 0.001)
    emit(ID_IDENT, pack([(0, 8, 4), (8, 32, f32(float(meta["tau"])))]), 0.001)
    emit(ID_CMD, pack([(0, 8, 1)], 4), 0.01)
    status(0, 0)
    emit(ID_CMD, pack([(0, 8, 3), (8, 8, seq), (16, 16, a.session)], 4), 0.01)
    hb = 0
    for k, (_, cur, w, th, h) in enumerate(rows):
        c = k % 16
        da = pack([(0, 16, k), (16, 4, c), (20, 16, round(cur / 0.002)), (36, 16, round(w / 0.05))])
        da[7] = crc8_j1850(da[:7])
        emit(ID_TA, da, period)
        db = pack([(0, 16, k), (16, 4, c), (20, 20, round(th / 0.001)), (40, 16, round(h / 0.5))])
        db[7] = crc8_j1850(db[:7])
        emit(ID_TB, db, 0.00002)
        if k % 5 == 4:
            status(1, k + 1)
        if k % 100 == 99:
            emit(ID_HB, pack([(0, 8, hb)], 1), 0.00001)
            hb = (hb + 1) % 256
    if a.abort:
        status(3, len(rows))
    elif not a.no_done:
        status(2, len(rows))
    emit(ID_CMD, pack([(0, 8, 2)], 4), 0.01)
    with open(a.out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
