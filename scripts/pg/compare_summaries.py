#!/usr/bin/env python3
"""The fleet server's summary tables against a reference, value for value (exact doubles).

  compare_summaries.py STATION_DB SERVER_URI [REFERENCE_URI]

Without REFERENCE_URI: the server's series_stats and position_status, restricted to the series of
the station file, must equal the station's own (SQLite) summary tables: every double bit for bit
(PostgreSQL prints the shortest text that reads back to the same double; Python reads both exactly).
With REFERENCE_URI: the server's whole summary tables must equal those of another server database.
Session ids differ between databases (each assigns its own), so last_session_id is compared as the
(station, station session id) it names. Prints one line; exit status 1 on any difference.
"""
import sqlite3
import subprocess
import sys

SERIES = ("tail_number, position, actuator_serial, parameter, n, first_days, last_days, s_w, s_wt, s_wtt, s_wy, s_wty, s_wyy, "
          "n_cycles, first_cycles, last_cycles, c_w, c_wt, c_wtt, c_wy, c_wty, c_wyy, last_session_id, last_value, last_std_error, "
          "limit_kind, limit_value")
POSITIONS = "tail_number, position, actuator_serial, sessions, last_session_id, last_utc, last_verdict, last_cycles"
SERIES_KEYS, POSITION_KEYS = 4, 2


def value(text):
    """A cell as Python compares it exactly: None, int, float, or str."""
    if text is None:
        return None
    if isinstance(text, (int, float)):
        return float(text) if isinstance(text, float) else text
    for conv in (int, float):
        try:
            return conv(text)
        except ValueError:
            pass
    return text


def server_rows(uri, table, columns):
    """Rows of a server table with last_session_id replaced by (station_uuid, station_session_id)."""
    cols = ", ".join("coalesce(s.station_uuid::text || ':' || s.station_session_id, 'missing')" if c.strip() == "last_session_id"
                     else "t." + c.strip() for c in columns.split(","))
    sql = (f"COPY (SELECT {cols} FROM {table} t LEFT JOIN test_sessions s ON s.session_id = t.last_session_id) TO STDOUT")
    out = subprocess.run(["psql", "-X", "-q", "-v", "ON_ERROR_STOP=1", uri, "-c", "SET extra_float_digits = 1", "-c", sql],
                         check=True, capture_output=True, text=True).stdout
    rows = []
    for line in out.splitlines():
        rows.append(tuple(None if f == "\\N" else value(f) for f in line.split("\t")))
    return rows


def station_rows(path, table, columns, station_uuid):
    con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    rows = []
    names = [c.strip() for c in columns.split(",")]
    for r in con.execute(f"SELECT {columns} FROM {table}"):
        rows.append(tuple(f"{station_uuid}:{v}" if n == "last_session_id" else value(v) for n, v in zip(names, r)))
    return rows


def same(a, b, keys, label):
    da = {r[:keys]: r for r in a}
    db = {r[:keys]: r for r in b}
    if da.keys() != db.keys():
        missing = sorted(set(da) - set(db))[:3]
        extra = sorted(set(db) - set(da))[:3]
        return f"{label}: rows differ (missing {missing}, extra {extra})"
    for k in sorted(da):
        x, y = da[k], db[k]
        for i, (u, v) in enumerate(zip(x, y)):
            if u != v and not (isinstance(u, float) and isinstance(v, float) and u != u and v != v):
                return f"{label} {k}: column {i} is {v!r}, expected {u!r}"
    return None


def main():
    if len(sys.argv) not in (3, 4):
        print(__doc__, file=sys.stderr)
        return 2
    station, uri = sys.argv[1], sys.argv[2]
    con = sqlite3.connect(f"file:{station}?mode=ro", uri=True)
    uuid = con.execute("SELECT station_uuid FROM station_identity").fetchone()[0]
    if len(sys.argv) == 4:
        want_s, want_p = server_rows(sys.argv[3], "series_stats", SERIES), server_rows(sys.argv[3], "position_status", POSITIONS)
        what = "the reference server database"
    else:
        want_s, want_p = station_rows(station, "series_stats", SERIES, uuid), station_rows(station, "position_status", POSITIONS, uuid)
        what = f"the station file {station}"
    got_s, got_p = server_rows(uri, "series_stats", SERIES), server_rows(uri, "position_status", POSITIONS)
    if len(sys.argv) == 3:  # only the station's series (the server may hold other stations' too)
        ks = {r[:SERIES_KEYS] for r in want_s}
        kp = {r[:POSITION_KEYS] for r in want_p}
        got_s = [r for r in got_s if r[:SERIES_KEYS] in ks]
        got_p = [r for r in got_p if r[:POSITION_KEYS] in kp]
    err = same(want_s, got_s, SERIES_KEYS, "series_stats") or same(want_p, got_p, POSITION_KEYS, "position_status")
    if err:
        print(f"summaries differ from {what}: {err}")
        return 1
    print(f"summaries equal to {what}: {len(got_s)} series_stats rows and {len(got_p)} position_status rows, every double exact")
    return 0


if __name__ == "__main__":
    sys.exit(main())
