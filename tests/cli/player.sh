#!/usr/bin/env bash
# The 3D player (docs/synthesis.md "3D player", docs/cli.md "mocap-search
# view") on set 1: mocap-synth --html, mocap-search --html and scripts/view
# write pages that headless Chromium (scripts/synth-setup), with every
# network request refused, runs from file:// with no console message; the
# player reports itself ready with the motions of the query; the figures
# play (the clock advances on its own), move (the view's pixels differ
# between screenshots one second of motion apart) and show the motion
# colours on the grid. The pages carry the motions as BVH (checked against
# the synthesised BVH) and the feet's contact states. Without the three.js
# copy mocap-synth still writes its report (saying why) and mocap-search
# refuses --html.
# Screenshots are kept in BUILD_DIR/test-artifacts/player/.
#   bash tests/cli/player.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup player "$@"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
chromium="${CHROMIUM:-$(command -v chromium || command -v chromium-browser || true)}"
[ -n "$chromium" ] || missing_tool scripts/synth-setup "chromium not found"
[ -x /usr/bin/python3 ] || missing_tool scripts/setup "/usr/bin/python3 not found"
pdir="${MOCAP_PLAYER_DIR:-$root/common/player/web}"
[ -f "$pdir/node_modules/three/build/three.module.js" ] ||
  missing_tool scripts/setup "no three.js copy in $pdir/node_modules"
art="$build/test-artifacts/player"
mkdir -p "$art"

"$indexer" build -q --out "$tmp/i.h5" "$data/bandai-namco-1" >/dev/null 2>&1
D=$(cd "$data" && pwd | sed 's/[\\&|]/\\&/g')
sed "s|@DATA@|$D|g" "$root/docs/examples/synth-query.json" >"$tmp/q.json"
sed "s|@DATA@|$D|g" "$root/docs/examples/queries.jsonl" | head -n 2 >"$tmp/qs.jsonl"

# The three pages.
"$synth" --index "$tmp/i.h5" --query "$tmp/q.json" --out "$tmp/m.bvh" --report "$tmp/report.json" \
  --html "$tmp/report.html" >/dev/null 2>"$tmp/synth.err" || fail "mocap-synth: $(cat "$tmp/synth.err")"
[ ! -s "$tmp/synth.err" ] || fail "mocap-synth warned: $(cat "$tmp/synth.err")"
"$search" --index "$tmp/i.h5" --queries "$tmp/qs.jsonl" --out "$tmp/r.jsonl" --html "$tmp/r.html" -q
# scripts/view writes R.html next to R.jsonl by default: the same bytes as
# mocap-search --html wrote there.
cp "$tmp/r.html" "$tmp/r-search.html"
MOCAP_BUILD_DIR="$build" "$root/scripts/view" "$tmp/r.jsonl" --index "$tmp/i.h5" >"$tmp/view.out"
grep -qx "html: $tmp/r.html" "$tmp/view.out" || fail "scripts/view wrote: $(cat "$tmp/view.out")"
cmp "$tmp/r.html" "$tmp/r-search.html" || fail "scripts/view and mocap-search --html differ"
first=$(/usr/bin/python3 -c 'import json,sys; print(json.loads(open(sys.argv[1]).readline())["id"])' "$tmp/qs.jsonl")
MOCAP_BUILD_DIR="$build" "$root/scripts/view" "$tmp/r.jsonl" --index "$tmp/i.h5" --out "$tmp/v.html" \
  --id "$first" >/dev/null

# Refusals: no index for scripts/view; no three.js copy.
if MOCAP_INDEX= MOCAP_BUILD_DIR="$build" "$root/scripts/view" "$tmp/r.jsonl" 2>"$tmp/e"; then
  fail "scripts/view without an index succeeded"
fi
grep -q -- "--index" "$tmp/e" || fail "scripts/view: $(cat "$tmp/e")"
set +e
MOCAP_PLAYER_DIR="$tmp/none" "$search" --index "$tmp/i.h5" --queries "$tmp/qs.jsonl" \
  --out "$tmp/r2.jsonl" --html "$tmp/r2.html" -q 2>"$tmp/e"
rc=$?
set -e
[ "$rc" = 2 ] || fail "mocap-search --html without three.js: exit $rc, expected 2"
grep -q "scripts/setup" "$tmp/e" && grep -q "$tmp/none" "$tmp/e" || fail "message: $(cat "$tmp/e")"
[ ! -e "$tmp/r2.html" ] && [ ! -e "$tmp/r2.jsonl" ] || fail "outputs written though --html was refused"
# --html is an output like --out (docs/cli.md "Output paths").
mkdir "$tmp/dir.html"
for bad in "$tmp/r3.jsonl" "$tmp/dir.html" "$tmp/qs.jsonl"; do
  set +e
  "$search" --index "$tmp/i.h5" --queries "$tmp/qs.jsonl" --out "$tmp/r3.jsonl" --html "$bad" -q 2>"$tmp/e"
  rc=$?
  set -e
  [ "$rc" = 2 ] && grep -q -- "--html\|--out\|--queries" "$tmp/e" || fail "--html $bad: exit $rc: $(cat "$tmp/e")"
done
[ ! -e "$tmp/r3.jsonl" ] || fail "results written though --html was refused"
MOCAP_PLAYER_DIR="$tmp/none" "$synth" --index "$tmp/i.h5" --query "$tmp/q.json" --out "$tmp/m2.bvh" \
  --html "$tmp/plain.html" >/dev/null 2>"$tmp/e"
grep -q "warning: the report has no 3D player" "$tmp/e" || fail "no warning: $(cat "$tmp/e")"
grep -q 'data-figure="player-missing"' "$tmp/plain.html" || fail "report does not say the player is missing"
grep -q 'data-figure="filmstrip-motion"' "$tmp/plain.html" || fail "report lost its filmstrips"

# The pages' data: motions as BVH, contacts per frame, marks.
/usr/bin/python3 - "$tmp" <<'PY'
import json, re, sys
t = sys.argv[1]
def data(page):
    text = open(page, encoding="utf-8").read()
    assert not re.search(r'(src|href)="(https?:)?//', text), page + ": external reference"
    m = re.search(r'<script type="application/json" id="mp-data">(.*?)</script>', text, re.S)
    assert m, page + ": no player data"
    for mod in ("mp-three-core", "mp-three-module", "mp-bvh-loader", "mp-orbit-controls", "mp-app"):
        assert f'id="{mod}"' in text, page + ": no " + mod
    return json.loads(m.group(1)), len(text)
rep, size = data(t + "/report.html")
print(f"report.html: {size / 1e6:.2f} MB")
(scene,) = rep["scenes"]
report = json.load(open(t + "/report.json"))
motion = scene["motions"][0]
assert motion["id"] == "motion" and motion["group"] == "synthesised"
assert motion["frames"] == report["motion"]["frames"], (motion["frames"], report["motion"]["frames"])
bvh = motion["bvh"]
assert bvh.startswith("HIERARCHY") and f"Frames: {motion['frames']}" in bvh
# Same frame count and frame time as the written motion.
m_bvh = open(t + "/m.bvh").read()
assert re.search(r"Frames:\s*(\d+)", m_bvh).group(1) == str(motion["frames"])
assert abs(float(re.search(r"Frame Time:\s*(\S+)", m_bvh).group(1)) - motion["frame_time_s"]) < 1e-9
pairs = len(report["chosen"])
queries = [m for m in scene["motions"] if m["attach"] == "motion"]
assert len(queries) == pairs + 1, len(queries)
partials = [m for m in scene["motions"] if m["group"].startswith("pair ")]
assert sum(m["chosen"] for m in partials) == pairs
for c in report["chosen"]:
    m = next(m for m in partials if m["chosen"] and m["group"] == f"pair {c['pair']}")
    assert m["frames"] == c["frames"] and m["first_frame"] == c["start_frame"], (m["label"], c)
kinds = {k["kind"] for k in scene["marks"]}
assert kinds == {"query", "transition", "partial"}, kinds
assert sum(k["kind"] == "query" for k in scene["marks"]) == pairs + 1
for m in scene["motions"]:
    assert len(m["contacts"]) == len(m["foot_joints"]) > 0, m["id"]
    for c in m["contacts"]:
        assert len(c) == m["frames"] and set(c) <= set("012"), m["id"]
states = "".join("".join(m["contacts"]) for m in scene["motions"])
assert "1" in states and "0" in states, "no foot ever on or off the ground"
res, size = data(t + "/r.html")
print(f"r.html: {size / 1e6:.2f} MB")
lines = [json.loads(l) for l in open(t + "/r.jsonl")]
assert [s["id"] for s in res["scenes"]] == [l["id"] for l in lines if "error" not in l]
for s, l in zip(res["scenes"], lines):
    n = sum(len(p["results"]) for p in l["pairs"])
    assert len(s["motions"]) == n, (s["id"], len(s["motions"]), n)
one, _ = data(t + "/v.html")
assert len(one["scenes"]) == 1 and one["scenes"][0]["id"] == lines[0]["id"]
PY

# Headless Chromium, no network (a dead proxy, every host unresolvable).
flags=(--headless --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader --disable-quic
       --no-first-run --disable-background-networking --disable-component-update --disable-sync
       --proxy-server=127.0.0.1:9 --host-resolver-rules="MAP * ~NOTFOUND"
       --enable-logging=stderr --v=0 --window-size=1280,1000 --hide-scrollbars)
run_chromium() {  # NAME PAGE BUDGET_MS ACTION...
  local name="$1" page="$2" budget="$3"
  shift 3
  timeout "${CHROMIUM_TIMEOUT:-180}" "$chromium" "${flags[@]}" --user-data-dir="$tmp/profile-$name" \
    --virtual-time-budget="$budget" "$@" "file://$page" >"$tmp/$name.out" 2>"$tmp/$name.log" || true
  # Chromium logs the page's console without its level: the player logs
  # nothing, so any message (an error, an uncaught exception, a three.js
  # warning) fails.
  if grep -a ":CONSOLE" "$tmp/$name.log" >"$tmp/$name.console"; then
    fail "$name: console messages: $(head -c 2000 "$tmp/$name.console")"
  fi
}
check_ready() {  # NAME: the dumped DOM says ready, no error, N motions
  local dom="$tmp/$1.out"
  grep -q 'data-player-state="ready"' "$dom" ||
    fail "$1: player not ready: $(grep -o 'data-player-[a-z]*="[^"]*"' "$dom" | head -5 | tr '\n' ' ')"
  grep -q 'data-player-error' "$dom" && fail "$1: $(grep -o 'data-player-error="[^"]*"' "$dom")"
  grep -q '<canvas' "$dom" || fail "$1: no canvas"
  return 0
}
# The report's DOM: its clock must have left 0 (below); a stalled headless
# run (a loaded machine) is tried again, up to three times.
for try in 1 2 3; do
  run_chromium "dom-report-$try" "$tmp/report.html" 4000 --dump-dom
  cp "$tmp/dom-report-$try.out" "$tmp/dom-report.out"
  grep -q 'data-player-time="[1-9]' "$tmp/dom-report.out" && break
  echo "note: dom-report: try $try: the clock did not advance" >&2
done
check_ready dom-report
n_motions=$(/usr/bin/python3 -c 'import json,re,sys; t=open(sys.argv[1]).read(); print(len(json.loads(re.search(r"id=\"mp-data\">(.*?)</script>", t, re.S).group(1))["scenes"][0]["motions"]))' "$tmp/report.html")
grep -q "data-player-motions=\"$n_motions\"" "$tmp/dom-report.out" || fail "dom-report: not $n_motions motions"
run_chromium dom-results "$tmp/r.html" 4000 --dump-dom
check_ready dom-results
view_of() { grep -o 'data-player-view="[^"]*"' "$tmp/$1.out" | sed 's/.*="\(.*\)"/\1/'; }
view=$(view_of dom-report)
view_results=$(view_of dom-results)
[ -n "$view" ] && [ -n "$view_results" ] || fail "no data-player-view (the canvas's place on the page)"

# It plays on its own: after the page's virtual time has run, the clock has
# left 0 (the page starts playing at t = 0) and the button offers pause.
time_of() { grep -o 'data-player-time="[0-9]*"' "$tmp/$1.out" | grep -o '[0-9][0-9]*'; }
played=$(time_of dom-report)
[ -n "$played" ] && [ "$played" -gt 0 ] || fail "dom-report: the clock did not advance (t = ${played:-none} ms)"
grep -q 'pause</button>' "$tmp/dom-report.out" || fail "dom-report: not playing"
# Two screenshots one second of motion apart (the page's #t=S&paused, so the
# moments do not depend on how fast this machine loads the page: playing
# loops, and two budgets a moment apart can land a whole loop apart), and
# one of the search page.
# Headless Chromium now and then hangs past its virtual-time budget on a
# loaded machine (CI's sanitizer run, two tests at once) and writes no
# picture: a shot is tried three times, each under 90 s, and a missing
# picture fails with Chromium's own log.
shoot() {  # NAME PAGE PNG
  local try
  for try in 1 2 3; do
    rm -f "$3"
    CHROMIUM_TIMEOUT=90 run_chromium "$1-$try" "$2" 3000 --screenshot="$3"
    [ -s "$3" ] && return 0
    echo "note: $1: try $try wrote no $3" >&2
  done
  fail "$1: Chromium wrote no screenshot in 3 tries: $(tail -c 1500 "$tmp/$1-3.log")"
}
shoot shot1 "$tmp/report.html#t=1.0&paused" "$art/report-1.png"
shoot shot2 "$tmp/report.html#t=2.0&paused" "$art/report-2.png"
shoot shot3 "$tmp/r.html" "$art/results.png"
/usr/bin/python3 "$root/tests/cli/lib/png_view.py" --moving "$view" "$art/report-1.png" "$art/report-2.png" \
  --figures "$view_results" "$art/results.png" || fail "screenshots (kept in $art)"
echo "ok: the 3D player runs offline, without console errors, and plays (screenshots in $art)"
