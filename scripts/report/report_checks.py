#!/usr/bin/env python3
"""Checks of the HTML maintenance report (docs/report-html.md), used by browser_check.sh.

  report_checks.py html FILE --plots N     the file itself: well-formed XML, no script, no URL
                                           (only in-page links), the CSP, N inline SVG plots
  report_checks.py png FILE                a browser screenshot shows the plots: not blank, and
                                           enough pixels of the points' blue, the limit's red and
                                           the band's tint (colours of src/report/html_report.cpp)

Prints what it measured; exits 1 naming every check that failed. Standard library only (the PNG is
decoded here with zlib: 8-bit greyscale/RGB/RGBA, non-interlaced, as Chromium writes them).
"""
import re
import struct
import sys
import xml.etree.ElementTree as ET
import zlib

# Colours of html_report.cpp and svg_plot.cpp, and how many pixels of each a screenshot of the
# report of a trend with points, a fit and a limit must show (the tolerance covers anti-aliasing).
POINT_RGB = (0x1F, 0x5F, 0xA8)
LIMIT_RGB = (0xC0, 0x39, 0x2B)
BAND_RGB = (247, 228, 215)  # #d2691e at opacity 0.18 over white
COLOUR_TOLERANCE = 24
BAND_TOLERANCE = 6
MIN_POINT_PIXELS = 150
MIN_LIMIT_PIXELS = 150
MIN_BAND_PIXELS = 1000
MIN_NON_WHITE_FRACTION = 0.02
WHITE_LEVEL = 245


def check_html(path, plots):
    problems = []
    text = open(path, encoding="utf-8").read()
    try:
        ET.fromstring(text.split("\n", 1)[1] if text.startswith("<!DOCTYPE") else text)
    except ET.ParseError as e:
        problems.append(f"not well-formed: {e}")
    lower = text.lower()
    for bad in ("<script", "javascript:", "<iframe", "<object", "<embed", "<img", "<link", "@import"):
        if bad in lower:
            problems.append(f"contains {bad!r}")
    for m in re.finditer(r"(?:https?|ftp|file)://|[\"'(]\s*data:", lower):
        context = lower[max(0, m.start() - 30):m.end() + 10]
        problems.append(f"URL scheme at offset {m.start()}: ...{context}...")
    for m in re.finditer(r'(?:href|src|xlink:href)\s*=\s*"([^"]*)"', text):
        if not m.group(1).startswith("#"):
            problems.append(f"link to {m.group(1)!r} (only in-page links allowed)")
    if "Content-Security-Policy" not in text or "default-src 'none'" not in text:
        problems.append("no Content-Security-Policy with default-src 'none'")
    svgs = text.count("<svg")
    if svgs != plots:
        problems.append(f"{svgs} inline SVG plots, expected {plots}")
    bars, bands, hlines = (text.count(f'class="{c}"') for c in ("errorbar", "band", "hline"))
    print(f"html: {path}: {len(text.encode('utf-8'))} bytes, {svgs} inline SVG plots, "
          f"{bars} error bars, {bands} bands, {hlines} limit lines")
    return problems


def read_png(path):
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG file")
    pos, idat, header = 8, [], None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
        pos += 12 + length
    width, height, depth, colour, _, _, interlace = header
    channels = {0: 1, 2: 3, 4: 2, 6: 4}.get(colour)
    if depth != 8 or channels is None or interlace != 0:
        raise ValueError(f"{path}: PNG depth {depth}, colour type {colour}, interlace {interlace} not supported")
    raw = zlib.decompress(b"".join(idat))
    stride = width * channels
    rows, prev = [], bytearray(stride)
    for y in range(height):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        if f == 1:
            for i in range(channels, stride):
                line[i] = (line[i] + line[i - channels]) & 0xFF
        elif f == 2:
            line = bytearray((a + b) & 0xFF for a, b in zip(line, prev))
        elif f == 3:
            for i in range(stride):
                left = line[i - channels] if i >= channels else 0
                line[i] = (line[i] + ((left + prev[i]) >> 1)) & 0xFF
        elif f == 4:
            for i in range(stride):
                a = line[i - channels] if i >= channels else 0
                b = prev[i]
                c = prev[i - channels] if i >= channels else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 0xFF
        elif f != 0:
            raise ValueError(f"{path}: row {y} has filter type {f}")
        rows.append(bytes(line))
        prev = line
    return width, height, channels, rows


def check_png(path):
    problems = []
    width, height, channels, rows = read_png(path)
    non_white = point = limit = band = 0
    for row in rows:
        for x in range(width):
            px = row[x * channels:x * channels + 3] if channels >= 3 else bytes([row[x * channels]] * 3)
            r, g, b = px[0], px[1], px[2]
            if r < WHITE_LEVEL or g < WHITE_LEVEL or b < WHITE_LEVEL:
                non_white += 1
            if abs(r - POINT_RGB[0]) + abs(g - POINT_RGB[1]) + abs(b - POINT_RGB[2]) <= COLOUR_TOLERANCE:
                point += 1
            elif abs(r - LIMIT_RGB[0]) + abs(g - LIMIT_RGB[1]) + abs(b - LIMIT_RGB[2]) <= COLOUR_TOLERANCE:
                limit += 1
            elif abs(r - BAND_RGB[0]) <= BAND_TOLERANCE and abs(g - BAND_RGB[1]) <= BAND_TOLERANCE and abs(b - BAND_RGB[2]) <= BAND_TOLERANCE:
                band += 1
    total = width * height
    fraction = non_white / total
    print(f"png: {path}: {width} x {height}, non-white {100 * fraction:.1f} %, point-blue {point} px, "
          f"limit-red {limit} px, band-tint {band} px")
    if fraction < MIN_NON_WHITE_FRACTION:
        problems.append(f"non-white fraction {fraction:.4f} < {MIN_NON_WHITE_FRACTION}: blank page")
    if point < MIN_POINT_PIXELS:
        problems.append(f"{point} point-blue pixels < {MIN_POINT_PIXELS}: no measured points drawn")
    if limit < MIN_LIMIT_PIXELS:
        problems.append(f"{limit} limit-red pixels < {MIN_LIMIT_PIXELS}: no limit line drawn")
    if band < MIN_BAND_PIXELS:
        problems.append(f"{band} band-tint pixels < {MIN_BAND_PIXELS}: no prediction band drawn")
    return problems


def main(argv):
    if len(argv) >= 3 and argv[1] == "html":
        plots = int(argv[argv.index("--plots") + 1]) if "--plots" in argv else 1
        problems = check_html(argv[2], plots)
    elif len(argv) == 3 and argv[1] == "png":
        problems = check_png(argv[2])
    else:
        print(__doc__, file=sys.stderr)
        return 2
    for p in problems:
        print(f"FAIL: {argv[2]}: {p}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
