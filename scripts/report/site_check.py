#!/usr/bin/env python3
"""Checks of the fleet site (`emadiag site`, docs/install.md), used by site_browser_check.sh.

  site_check.py files SITE_DIR            every page: well-formed, no script, no URL scheme, the CSP
                                          of default-src 'none'; every link relative, inside the site,
                                          to a file that exists and, with a #fragment, to an id it holds
                                          every other file (the CSV lists of summarised sections)
                                          linked from a page; each summarised section's list holds
                                          as many sessions as its page says it has
  site_check.py dom SITE_DIR PAGE DOM     the links of PAGE as the browser built its DOM (--dump-dom
                                          output DOM) resolve the same way

Prints what it checked; exits 1 naming every problem. Standard library only.
"""
import os
import re
import sys
import urllib.parse
import xml.etree.ElementTree as ET

HREF = re.compile(r'(?:href|src|xlink:href)\s*=\s*"([^"]*)"')
ID = re.compile(r'\sid="([^"]*)"')
# A summarised section's note: its session count and the link to the list of every session.
SUMMARY = re.compile(r'Long history: (\d+) sessions\.[^<]*<a class="full-history" href="([^"]*)"')
FORBIDDEN = ("<script", "javascript:", "<iframe", "<object", "<embed", "<img", "<link", "@import")


def ids_of(path, cache={}):
    if path not in cache:
        cache[path] = set(ID.findall(open(path, encoding="utf-8").read()))
    return cache[path]


def check_links(site, page, text, problems):
    """Every link of `page` (a file inside `site`) resolves; returns how many links were checked."""
    n = 0
    for href in HREF.findall(text):
        n += 1
        href = href.replace("&amp;", "&")
        parts = urllib.parse.urlsplit(href)
        if parts.scheme or parts.netloc:
            problems.append(f"{page}: link with a scheme or host: {href!r}")
            continue
        target = page if not parts.path else os.path.normpath(os.path.join(os.path.dirname(page), urllib.parse.unquote(parts.path)))
        if os.path.commonpath([os.path.realpath(target), os.path.realpath(site)]) != os.path.realpath(site):
            problems.append(f"{page}: link leaves the site: {href!r}")
            continue
        if not os.path.isfile(target):
            problems.append(f"{page}: link to a missing file: {href!r} ({target})")
            continue
        if parts.fragment and urllib.parse.unquote(parts.fragment) not in ids_of(target):
            problems.append(f"{page}: link to a missing anchor: {href!r}")
    return n


def check_files(site):
    problems = []
    pages = []
    for d, _, files in os.walk(site):
        pages += [os.path.join(d, f) for f in files if f.endswith(".html")]
    links = 0
    for page in sorted(pages):
        text = open(page, encoding="utf-8").read()
        try:
            ET.fromstring(text.split("\n", 1)[1] if text.startswith("<!DOCTYPE") else text)
        except ET.ParseError as e:
            problems.append(f"{page}: not well-formed: {e}")
        lower = text.lower()
        for bad in FORBIDDEN:
            if bad in lower:
                problems.append(f"{page}: contains {bad!r}")
        for m in re.finditer(r"(?:https?|ftp|file)://|[\"'(]\s*data:", lower):
            problems.append(f"{page}: URL scheme at offset {m.start()}")
        if "Content-Security-Policy" not in text or "default-src 'none'" not in text:
            problems.append(f"{page}: no Content-Security-Policy with default-src 'none'")
        links += check_links(site, page, text, problems)
    index = os.path.join(site, "index.html")
    if index not in pages:
        problems.append("no index.html")
    else:
        index_text = open(index, encoding="utf-8").read()
        for page in pages:
            if page == index:
                continue
            rel = os.path.relpath(page, site)
            if f'href="{rel}"' not in index_text and f'href="{rel}#' not in index_text:
                problems.append(f"index.html does not link {rel}")
            if 'href="../index.html"' not in open(page, encoding="utf-8").read():
                problems.append(f"{rel} does not link back to the index")
    problems += check_lists(site, pages)
    print(f"files: {len(pages)} pages, {links} links checked, {sum(os.path.getsize(p) for p in pages)} bytes")
    return problems


def check_lists(site, pages):
    """Every file that is not a page is linked from a page; each summarised section's list has a header
    and one line per session the page counts."""
    problems = []
    linked = set()
    summaries = 0
    for page in pages:
        text = open(page, encoding="utf-8").read()
        for href in HREF.findall(text):
            path = urllib.parse.urlsplit(href.replace("&amp;", "&")).path
            if path:
                linked.add(os.path.normpath(os.path.join(os.path.dirname(page), urllib.parse.unquote(path))))
        for sessions, href in SUMMARY.findall(text):
            summaries += 1
            target = os.path.normpath(os.path.join(os.path.dirname(page), urllib.parse.unquote(href)))
            if not os.path.isfile(target):
                continue  # check_links names it
            with open(target, encoding="utf-8") as f:
                lines = f.read().splitlines()
            if not lines or not lines[0].startswith("session,started_utc,"):
                problems.append(f"{target}: no header row")
            elif len(lines) - 1 != int(sessions):
                problems.append(f"{page}: says {sessions} sessions, {href} lists {len(lines) - 1}")
    for d, _, files in os.walk(site):
        for f in files:
            path = os.path.normpath(os.path.join(d, f))
            if f.endswith(".html") or f == ".emadiag-site":
                continue
            if path not in linked:
                problems.append(f"{os.path.relpath(path, site)} is linked from no page")
    print(f"lists: {summaries} summarised section(s) with their session lists checked")
    return problems


def check_dom(site, page, dom):
    problems = []
    n = check_links(site, os.path.join(site, page), open(dom, encoding="utf-8").read(), problems)
    print(f"dom: {page}: {n} links in the browser's DOM checked")
    if n == 0:
        problems.append(f"{page}: the browser's DOM holds no link")
    return problems


def main():
    if len(sys.argv) == 3 and sys.argv[1] == "files":
        problems = check_files(sys.argv[2])
    elif len(sys.argv) == 5 and sys.argv[1] == "dom":
        problems = check_dom(sys.argv[2], sys.argv[3], sys.argv[4])
    else:
        print(__doc__, file=sys.stderr)
        return 2
    for p in problems:
        print(f"FAIL: {p}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
