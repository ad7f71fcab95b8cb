#!/usr/bin/env bash
# check_render.sh REPORT_HTML [SCREENSHOT_PNG]
#
# Opens the page in headless Chromium and checks that it renders: after load, every <img>
# decoded (complete and naturalWidth > 0) and there are at least MIN_IMGS of them (default 5).
# With REQUIRE_IDS="a b ...", each id must be an element of the rendered DOM (the report's
# sections: e.g. "tests unexplained changes auto"), and with MIN_ALT="TEXT:N" at least N images
# whose alt text starts with TEXT must have decoded (several: "TEXT:N|TEXT2:M").
# Also takes a screenshot at a laptop's width (1366 px; SHOT_HEIGHT, default 2400) and checks
# it is a non-empty PNG; with SCREENSHOT_PNG it is kept there, otherwise it goes to a temporary
# directory that is removed. One browser start does both (--dump-dom with --screenshot): the
# probe's output is hidden (display:none), so the screenshot shows the page as it is.
#
# Browser: $CHROMIUM if set, else /usr/bin/chromium, else chromium / chromium-browser on PATH.
# Exit: 0 rendered fine; 1 a check failed (the reason is printed); 2 bad usage or unreadable
# page; 77 no Chromium found (the "skipped" code of ctest's SKIP_RETURN_CODE and automake).
set -u

usage() { echo "usage: check_render.sh REPORT_HTML [SCREENSHOT_PNG]" >&2; exit 2; }
if [ $# -lt 1 ] || [ $# -gt 2 ]; then usage; fi
page=$1
shot_out=${2:-}
min_imgs=${MIN_IMGS:-5}
budget_ms=${RENDER_BUDGET_MS:-5000}
[ -r "$page" ] || { echo "check_render: cannot read '$page'" >&2; exit 2; }

browser=${CHROMIUM:-}
if [ -z "$browser" ]; then
  for c in /usr/bin/chromium chromium chromium-browser; do
    if command -v "$c" >/dev/null 2>&1; then browser=$(command -v "$c"); break; fi
  done
fi
if [ -z "$browser" ] || ! command -v "$browser" >/dev/null 2>&1; then
  echo "check_render: SKIPPED: no Chromium (install the Debian package 'chromium' or set CHROMIUM)" >&2
  exit 77
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/check_render.XXXXXX") || exit 2
trap 'rm -rf "$work"' EXIT

# The page under test has no script of its own; the probe is added to a copy only.
probe='<script>
window.addEventListener("load", function () {
  var imgs = document.images, broken = 0, bad = [], alts = [];
  for (var i = 0; i < imgs.length; i++) {
    if (!imgs[i].complete || !(imgs[i].naturalWidth > 0)) { broken++; bad.push(i); }
    else alts.push(imgs[i].alt);
  }
  var a = document.createElement("pre");
  a.id = "render-alts";
  a.style.display = "none";
  a.textContent = alts.map(function (x) { return "ALT:" + x; }).join(String.fromCharCode(10));
  document.body.appendChild(a);
  var m = document.createElement("pre");
  m.id = "render-probe";
  m.style.display = "none";
  m.textContent = "RENDER_OK imgs=" + imgs.length + " broken=" + broken + " bad=[" + bad.join(",") + "]";
  document.body.appendChild(m);
});
</script>'
cp -- "$page" "$work/page.html" || exit 2
if grep -qi '</body>' "$work/page.html"; then
  # Before the last </body>; awk keeps this linear in the page size (pages are megabytes).
  awk -v probe="$probe" '
    { lines[NR] = $0 }
    END {
      last = 0
      for (i = 1; i <= NR; i++) if (tolower(lines[i]) ~ /<\/body>/) last = i
      for (i = 1; i <= NR; i++) {
        if (i == last) {
          l = lines[i]; p = 0; s = tolower(l)
          while ((k = index(substr(s, p + 1), "</body>")) > 0) p += k
          print substr(l, 1, p - 1) probe substr(l, p)
        } else print lines[i]
      }
    }' "$page" > "$work/probe.html" || exit 2
else
  { cat -- "$page"; printf '%s\n' "$probe"; } > "$work/probe.html"
fi

run_chromium() {  # extra flags...; stdout is the browser's
  timeout 120 "$browser" --headless --no-sandbox --disable-gpu --disable-dev-shm-usage \
    --no-first-run --no-default-browser-check --disable-extensions --mute-audio \
    --hide-scrollbars --user-data-dir="$work/profile" \
    --virtual-time-budget="$budget_ms" "$@" 2>>"$work/chromium.log"
}

shot=${shot_out:-$work/shot.png}
rm -f -- "$shot"
run_chromium --window-size=1366,${SHOT_HEIGHT:-2400} --screenshot="$shot" --dump-dom "file://$work/probe.html" \
  > "$work/dom.html"
rc=$?
marker=$(grep -o 'RENDER_OK imgs=[0-9]* broken=[0-9]* bad=\[[0-9,]*\]' "$work/dom.html" | tail -n 1)
if [ -z "$marker" ]; then
  echo "check_render: FAIL: the page did not finish loading in Chromium (exit $rc, no probe marker)" >&2
  tail -n 20 "$work/chromium.log" >&2
  exit 1
fi
imgs=$(sed -E 's/.*imgs=([0-9]+).*/\1/' <<<"$marker")
broken=$(sed -E 's/.*broken=([0-9]+).*/\1/' <<<"$marker")
echo "check_render: $marker"
fail=0
if [ "$broken" -ne 0 ]; then
  echo "check_render: FAIL: $broken of $imgs image(s) did not decode (indices in bad=[...])" >&2
  fail=1
fi
if [ "$imgs" -lt "$min_imgs" ]; then
  echo "check_render: FAIL: only $imgs image(s), expected at least $min_imgs" >&2
  fail=1
fi
for id in ${REQUIRE_IDS:-}; do
  if ! grep -q "id=\"$id\"" "$work/dom.html"; then
    echo "check_render: FAIL: the rendered page has no element with id=\"$id\" (a section is missing)" >&2
    fail=1
  fi
done
if [ -n "${MIN_ALT:-}" ]; then
  IFS='|' read -r -a alt_specs <<<"$MIN_ALT"
  for spec in "${alt_specs[@]}"; do
    alt_text=${spec%:*}; alt_min=${spec##*:}
    n_alt=$(grep -o "ALT:$alt_text" "$work/dom.html" | wc -l)
    echo "check_render: $n_alt decoded image(s) with alt \"$alt_text...\""
    if [ "$n_alt" -lt "$alt_min" ]; then
      echo "check_render: FAIL: $n_alt image(s) with alt \"$alt_text...\", expected at least $alt_min" >&2
      fail=1
    fi
  done
fi
# The page itself must not reach out: no http(s) or protocol-relative src/href/url().
if grep -Eqi "(src|href)=[\"']?(https?:)?//|url\([\"']?(https?:)?//" "$page"; then
  echo "check_render: FAIL: the page refers to an external resource:" >&2
  grep -Eoi "(src|href)=[\"']?(https?:)?//[^\"' >]{0,80}|url\([\"']?(https?:)?//[^)]{0,80}" "$page" | head -n 3 >&2
  fail=1
fi

if [ ! -s "$shot" ] || [ "$(head -c 8 "$shot" | od -An -tx1 | tr -d ' \n')" != "89504e470d0a1a0a" ]; then
  echo "check_render: FAIL: no screenshot PNG was written" >&2
  tail -n 20 "$work/chromium.log" >&2
  fail=1
else
  echo "check_render: screenshot $(wc -c <"$shot") bytes${shot_out:+ -> $shot_out}"
fi
[ "$fail" -eq 0 ] && echo "check_render: OK: $page"
exit "$fail"
