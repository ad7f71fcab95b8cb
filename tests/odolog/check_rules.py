#!/usr/bin/env python3
"""check_rules.py: docs/odolog.md against the odolog reader, through `odoerr replay`.

Usage: check_rules.py ODOERR --work DIR [--doc docs/odolog.md]

- The doc's rule ids: every `(rule R7)` in the text names a row of one of its refusal
  tables (`| R7 | what | `message` |`), each id has one row, and the ids of those rows are
  exactly the rules of tests/odolog/expect.tsv.
- Each row of expect.tsv (rule, case, line, message) replays cases/CASE.odolog: the exit
  status must be 1 and stderr must hold `CASE:LINE: MESSAGE...` (`CASE: MESSAGE...` when
  LINE is -), where the text after `CASE:LINE: ` starts with MESSAGE and matches the
  doc's message for that rule as a whole (`<...>` in the doc stands for any text). Every
  file in cases/ has a row, and every row a file.
- The doc's example (its one ```odolog block) is accepted, as is the same text with CRLF
  line ends; the example holds every record type.
- Every file in accept/ is accepted; a line `# check: KEY=VALUE` in it compares
  replay.json's KEY (a dotted path into its objects, e.g. encoder_rejections.count) with
  VALUE.

Exit status 0 when everything holds, 1 otherwise (each failure printed), 2 bad usage.
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
RECORD_TYPES = {"odolog", "drive", "param", "laser", "wall", "init", "meta", "enc", "scan", "pose", "truth"}
RULE_ROW = re.compile(r"^\| ([RC]\d+) \| (.+?) \| `(.+)` \|$")
RULE_TAG = re.compile(r"\(rules? ([^)]*)\)")
RULE_ID = re.compile(r"\b[RC]\d+\b")


def doc_rules(text):
    """({id: message template}, set of tagged ids, [problems])."""
    problems, rows, tagged = [], {}, set()
    for n, line in enumerate(text.splitlines(), 1):
        m = RULE_ROW.match(line)
        if m:
            if m.group(1) in rows:
                problems.append(f"doc line {n}: rule {m.group(1)} has a second row")
            rows[m.group(1)] = m.group(3)
        for t in RULE_TAG.finditer(line):
            tagged.update(RULE_ID.findall(t.group(1)))
    for r in sorted(tagged - set(rows)):
        problems.append(f"doc: '(rule {r})' is used but no refusal table row defines {r}")
    return rows, tagged, problems


def template_regex(template):
    parts = re.split(r"<[^<>]+>", template)
    return re.compile(".+?".join(re.escape(p) for p in parts) + r"\Z")


def doc_example(text):
    blocks = re.findall(r"^```odolog\n(.*?)^```$", text, flags=re.S | re.M)
    return blocks


def replay(odoerr, cwd, name, out):
    shutil.rmtree(out, ignore_errors=True)
    try:
        p = subprocess.run([odoerr, "replay", name, "--out", out], cwd=cwd, capture_output=True, text=True,
                           errors="replace", timeout=120)
    except subprocess.TimeoutExpired:
        return None, "timed out after 120 s"
    return p.returncode, p.stderr


def main(argv=None):
    ap = argparse.ArgumentParser(prog="check_rules.py", description=__doc__.split("\n")[0])
    ap.add_argument("odoerr")
    ap.add_argument("--work", required=True, help="scratch directory (replay outputs)")
    ap.add_argument("--doc", default=os.path.join(HERE, "..", "..", "docs", "odolog.md"))
    a = ap.parse_args(argv)
    odoerr = os.path.abspath(a.odoerr)
    work = os.path.abspath(a.work)
    if not os.access(odoerr, os.X_OK):
        print(f"check_rules.py: {a.odoerr}: not an executable", file=sys.stderr)
        return 2
    os.makedirs(work, exist_ok=True)
    fails = []
    with open(a.doc, encoding="utf-8") as f:
        doc = f.read()

    # 1. The doc's ids against expect.tsv.
    templates, tagged, problems = doc_rules(doc)
    fails += problems
    if not templates:
        fails.append(f"{a.doc}: no refusal table rows (| R1 | what | `message` |)")
    rows = []
    with open(os.path.join(HERE, "expect.tsv"), encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            if not line.strip() or line.startswith("#"):
                continue
            cols = line.rstrip("\n").split("\t")
            if len(cols) != 4 or not RULE_ID.fullmatch(cols[0]) or not (cols[2] == "-" or cols[2].isdigit()):
                fails.append(f"expect.tsv:{n}: expected RULE<TAB>CASE<TAB>LINE|-<TAB>MESSAGE")
                continue
            rows.append((n, *cols))
    tsv_rules = {r[1] for r in rows}
    for r in sorted(set(templates) - tsv_rules):
        fails.append(f"{a.doc}: rule {r} has no case in expect.tsv")
    for r in sorted(tsv_rules - set(templates)):
        fails.append(f"expect.tsv: rule {r} is not in {a.doc}'s refusal tables")
    for r in sorted(set(templates) - tagged):
        fails.append(f"{a.doc}: rule {r} is in a refusal table but never cited as '(rule {r})' in the text")

    # 2. Every case is refused as expect.tsv and the doc say.
    cases_dir = os.path.join(HERE, "cases")
    files = {f[:-len(".odolog")] for f in os.listdir(cases_dir) if f.endswith(".odolog")}
    names = [r[2] for r in rows]
    for c in sorted(files - set(names)):
        fails.append(f"cases/{c}.odolog: not in expect.tsv")
    for c in sorted({c for c in names if names.count(c) > 1}):
        fails.append(f"expect.tsv: case {c} listed more than once")
    checked = 0
    for n, rule, case, line, message in rows:
        name = case + ".odolog"
        if case not in files:
            fails.append(f"expect.tsv:{n}: cases/{name} does not exist")
            continue
        rc, err = replay(odoerr, cases_dir, name, os.path.join(work, "case-" + case))
        where = f"cases/{name} ({rule})"
        if rc != 1:
            fails.append(f"{where}: exit status {rc}, expected 1 (refused); stderr: {err.strip()[:300]}")
            continue
        prefix = f"{name}:{line}: " if line != "-" else f"{name}: "
        got = [ln.split(prefix, 1)[1] for ln in err.splitlines() if prefix in ln]
        if not got:
            fails.append(f"{where}: no '{prefix}...' on stderr; got: {err.strip()[:300]}")
            continue
        text = got[0]
        if not text.startswith(message):
            fails.append(f"{where}: message '{text}' does not start with expect.tsv's '{message}'")
        elif rule in templates and not template_regex(templates[rule]).match(text):
            fails.append(f"{where}: message '{text}' does not match the doc's '{templates[rule]}'")
        else:
            checked += 1

    # 3. The doc's example is accepted (LF and CRLF) and shows every record type.
    blocks = doc_example(doc)
    example_ok = len(blocks) == 1
    if len(blocks) != 1:
        fails.append(f"{a.doc}: expected one ```odolog block (the example), found {len(blocks)}")
    else:
        types = {ln.split()[0] for ln in blocks[0].splitlines() if ln.split() and not ln.startswith("#")}
        if RECORD_TYPES - types:
            fails.append(f"{a.doc}: the example lacks the record types {sorted(RECORD_TYPES - types)}")
        for tag, text in (("example", blocks[0]), ("example-crlf", blocks[0].replace("\n", "\r\n"))):
            with open(os.path.join(work, tag + ".odolog"), "w", encoding="utf-8", newline="") as f:
                f.write(text)
            rc, err = replay(odoerr, work, tag + ".odolog", os.path.join(work, tag + "-out"))
            if rc != 0:
                example_ok = False
                fails.append(f"{a.doc}: the example ({tag}) is refused: exit {rc}: {err.strip()[:300]}")

    # 4. The accepted variants.
    acc_dir = os.path.join(HERE, "accept")
    accepted = sorted(f for f in os.listdir(acc_dir) if f.endswith(".odolog"))
    n_accepted = 0
    for name in accepted:
        out = os.path.join(work, "accept-" + name[:-len(".odolog")])
        rc, err = replay(odoerr, acc_dir, name, out)
        if rc != 0:
            fails.append(f"accept/{name}: exit {rc}, expected 0: {err.strip()[:300]}")
            continue
        with open(os.path.join(acc_dir, name), encoding="utf-8") as f:
            checks = re.findall(r"^# check: (\w+(?:\.\w+)*)=(\S+)$", f.read(), flags=re.M)
        with open(os.path.join(out, "replay.json"), encoding="utf-8") as f:
            summary = json.load(f)

        def get(key):  # a dotted key walks into objects
            v = summary
            for part in key.split("."):
                v = v.get(part) if isinstance(v, dict) else None
            return v
        bad = [(k, get(k), v) for k, v in checks if str(get(k)) != v]
        for key, got, want in bad:
            fails.append(f"accept/{name}: replay.json {key} = {got}, expected {want}")
        n_accepted += not bad

    for f in fails:
        print(f"FAIL {f}")
    print(f"odolog rules: {len(templates)} in the doc, {checked}/{len(rows)} cases refused as expected, "
          f"example {'accepted' if example_ok else 'FAILED'}, {n_accepted}/{len(accepted)} accept/ files accepted; "
          f"{len(fails)} failure(s)")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
