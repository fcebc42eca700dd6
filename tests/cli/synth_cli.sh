#!/usr/bin/env bash
# mocap-synth end to end on set 1: invalid inputs first (bad pick, missing
# results, unknown clip, query id absent, skeleton/frame-rate mismatch), then a
# 3-frame query with explicit results -> BVH + REPORT.json, checked for the
# assembly (query, transition, partial, ... segments), the measures, and
# determinism (two runs give the same BVH), a timed in-between and --fps.
#   bash tests/cli/synth_cli.sh BUILD_DIR DATA_DIR
set -euo pipefail
build="${1:?usage: synth_cli.sh BUILD_DIR DATA_DIR}"
data="${2:?usage: synth_cli.sh BUILD_DIR DATA_DIR}"
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
synth="$build/synth/mocap-synth"
indexer="$build/indexer/mocap-index"
[ -x "$synth" ] || { echo "FAIL: $synth not built" >&2; exit 1; }
[ -x "$indexer" ] || { echo "FAIL: $indexer not built" >&2; exit 1; }
[ -d "$data/bandai-namco-1/data" ] || { echo "SKIP: no data at $data"; exit 77; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
"$indexer" build --out "$tmp/index.h5" "$data/bandai-namco-1" "$data/cmu" >/dev/null 2>&1
python3 "$here/../synth/synth_fixture.py" --index-data "$data" --out "$tmp" >/dev/null

fail() { echo "FAIL: $*" >&2; exit 1; }
expect_error() {  # expect_error PATTERN ARGS...
  local pattern="$1"; shift
  if "$synth" "$@" >"$tmp/out.txt" 2>"$tmp/err.txt"; then fail "expected an error for: $*"; fi
  grep -q -- "$pattern" "$tmp/err.txt" || { cat "$tmp/err.txt" >&2; fail "message '$pattern' missing for: $*"; }
}
base=(--index "$tmp/index.h5" --query "$tmp/query.json" --out "$tmp/m.bvh")
expect_error "expected PAIR:RANK" "${base[@]}" --results "$tmp/results.jsonl" --pick 1-2
expect_error "pair 5 out of range" "${base[@]}" --results "$tmp/results.jsonl" --pick 5:1
expect_error "has no result of rank 9" "${base[@]}" --results "$tmp/results.jsonl" --pick 1:9
expect_error "cannot read the search results" "${base[@]}" --results "$tmp/missing.jsonl"
expect_error "unknown clip" "${base[@]}" --results "$tmp/unknown-clip.jsonl"
expect_error "no results for query" "${base[@]}" --results "$tmp/other-id.jsonl"
expect_error "frame time" "${base[@]}" --results "$tmp/cmu-mix.jsonl"
expect_error "expected astar, slerp or inertialize" "${base[@]}" --results "$tmp/results.jsonl" --transition foo
expect_error "refine" "${base[@]}" --results "$tmp/results.jsonl" --refine -3
expect_error "refine-smoothing" "${base[@]}" --results "$tmp/results.jsonl" --refine 8 --refine-smoothing -1
expect_error "refine-polish-window" "${base[@]}" --results "$tmp/results.jsonl" --refine-polish 2 --refine-polish-window 0
expect_error "refine-polish-smoothing" "${base[@]}" --results "$tmp/results.jsonl" --refine-polish 2 --refine-polish-smoothing -1
expect_error "excludes" "${base[@]}" --results "$tmp/results.jsonl" --step-feet --no-step-feet
expect_error "energy" "${base[@]}" --results "$tmp/results.jsonl" --energy x
expect_error "unknown joint" --index "$tmp/index.h5" --query "$tmp/bad-joint.json" --results "$tmp/results.jsonl" --out "$tmp/m.bvh"
[ ! -e "$tmp/m.bvh" ] || fail "an output was written by a failing run"

"$synth" "${base[@]}" --results "$tmp/results.jsonl" --report "$tmp/r.json" --html "$tmp/r.html" >"$tmp/out.txt"
grep -q "^motion: .*m.bvh" "$tmp/out.txt" || fail "motion path not printed"
"$synth" "${base[@]/m.bvh/m2.bvh}" --results "$tmp/results.jsonl" >/dev/null
cmp -s "$tmp/m.bvh" "$tmp/m2.bvh" || fail "two runs gave different motions"
# The gaps run in parallel: one thread gives the same motion and report.
"$synth" "${base[@]/m.bvh/m1.bvh}" --results "$tmp/results.jsonl" --threads 1 --report "$tmp/r1.json" >/dev/null
cmp -s "$tmp/m.bvh" "$tmp/m1.bvh" || fail "--threads 1 gave a different motion"
"$synth" "${base[@]/m.bvh/ms.bvh}" --results "$tmp/results.jsonl" --transition slerp --report "$tmp/rs.json" >/dev/null
"$synth" "${base[@]/m.bvh/mp.bvh}" --results "$tmp/results.jsonl" --pick 1:2 --report "$tmp/rp.json" >/dev/null
# --step-feet: the stepping pass where the search's legs skate; --no-step-feet
# is the default's own legs.
"$synth" "${base[@]/m.bvh/mn.bvh}" --results "$tmp/results.jsonl" --step-feet --report "$tmp/rn.json" >/dev/null
"$synth" "${base[@]/m.bvh/m3.bvh}" --results "$tmp/results.jsonl" --no-step-feet >/dev/null
cmp -s "$tmp/m.bvh" "$tmp/m3.bvh" || fail "--no-step-feet is not the default"
# --refine: the same transitions' lengths, g never above the unrefined run's.
"$synth" "${base[@]/m.bvh/mr.bvh}" --results "$tmp/results.jsonl" --refine 5 --report "$tmp/rr.json" >/dev/null
# --refine-smoothing: smoothed stages first, the same guarantees.
"$synth" "${base[@]/m.bvh/mq.bvh}" --results "$tmp/results.jsonl" --refine 8 --refine-smoothing 1 --report "$tmp/rq.json" >/dev/null
# Polishing alone, with runs, segments and a smoothed pass: the same guarantees.
"$synth" "${base[@]/m.bvh/mw.bvh}" --results "$tmp/results.jsonl" --refine-polish 2 --refine-polish-window 4 \
  --refine-polish-segments --refine-polish-smoothing 0.3 --report "$tmp/rw.json" >/dev/null
python3 - "$tmp" <<'PY'
import json, sys
t = sys.argv[1]
def slide_limit(a, b):
    """The refinement slides the feet no more than the slerp of the same
    length or the path it starts from (the search on W has no sliding
    limit of its own), or than the stepped path it starts from
    (docs/synthesis.md)."""
    if b["search"]["stepped"]:
        return a["foot_sliding_m"]
    return max(a["foot_sliding_m"], b["baselines_same_length"]["slerp"]["foot_sliding_m"])
r = json.load(open(t + "/r.json"))
rw = json.load(open(t + "/rw.json"))
p = rw["parameters"]
assert (p["refine_iterations"], p["refine_polish_sweeps"], p["refine_polish_window"]) == (0, 2, 4), p
assert p["refine_polish_segments"] is True and p["refine_polish_smoothing_J"] == 0.3, p
assert r["parameters"]["refine_polish_window"] == 1 and r["parameters"]["refine_polish_segments"] is False
for a, b in zip(r["transitions"], rw["transitions"]):
    assert b["frames"] == a["frames"]
    assert abs(a["g_J"] - b["g_J"] - b["search"]["refine_gain_J"]) <= 1e-6 * a["g_J"], (a["g_J"], b["g_J"])
    assert b["g_J"] <= a["g_J"] and b["foot_sliding_m"] <= slide_limit(a, b) + 1e-9
assert sum(b["search"]["refine_gain_J"] for b in rw["transitions"]) > 0
rr = json.load(open(t + "/rr.json"))
r1 = json.load(open(t + "/r1.json"))
def untimed(rep):
    rep = json.loads(json.dumps(rep))
    del rep["timings_ms"]
    for tr in rep["transitions"]:
        del tr["time_ms"]
    rep["motion"]["bvh"] = None
    return rep
assert untimed(r1) == untimed(r), "--threads 1 gave a different report"
rq = json.load(open(t + "/rq.json"))
assert r["parameters"]["refine_iterations"] == 0 and rr["parameters"]["refine_iterations"] == 5
assert r["parameters"]["refine_smoothing_J"] == 0 and rq["parameters"]["refine_smoothing_J"] == 1
for refined, most in ((rr, 5), (rq, 8)):
    for a, b in zip(r["transitions"], refined["transitions"]):
        assert a["search"]["refine_steps"] == 0 and a["search"]["refine_gain_J"] == 0
        assert b["frames"] == a["frames"] and b["search"]["refine_steps"] <= most
        assert abs(a["g_J"] - b["g_J"] - b["search"]["refine_gain_J"]) <= 1e-6 * a["g_J"], (a["g_J"], b["g_J"])
        assert b["g_J"] <= a["g_J"] and b["foot_sliding_m"] <= slide_limit(a, b) + 1e-9
assert sum(b["search"]["refine_steps"] for b in rr["transitions"]) > 0
segs = r["motion"]["segments"]
kinds = [s["kind"] for s in segs]
assert kinds == ["query", "transition", "partial", "transition", "query", "transition", "partial", "transition", "query"], kinds
assert sum(s["frames"] for s in segs) == r["motion"]["frames"]
assert len(r["motion"]["step_energies_J"]) == r["motion"]["frames"] - 1
for s in segs:
    if s["kind"] == "partial":
        c = r["chosen"][s["pair"] - 1]
        assert s["frames"] == c["end_frame"] - c["start_frame"] + 1
        assert 0 <= s["foot_skating_ratio"] <= 1 and 0 <= s["airborne_ratio"] <= 1, s
assert len(r["transitions"]) == 4
for tr in r["transitions"]:
    assert tr["method"] == "astar" and tr["frames"] >= 0
    assert tr["g_J"] >= tr["h_J"] >= 0, tr
    assert len(tr["step_energies_J"]) == tr["frames"] + 1
    assert tr["frames"] <= r["parameters"]["max_states"]
    for k in ("foot_sliding_m", "range_violations", "peak_angular_speed_radps"):
        assert tr[k] >= 0
    assert 0 <= tr["airborne_ratio"] <= 1 and isinstance(tr["search"]["stepped"], bool), tr
    assert "slerp" in tr["baselines_same_length"] and "inertialize" in tr["baselines_same_length"]
    assert tr["search"]["stop_reason"] in ("threshold", "horizon", "max_states")
# The defaults: the search on W, no stepping pass.
assert r["parameters"]["energy"] == "w" and r["parameters"]["step_feet"] is False
assert 0 <= r["motion"]["airborne_ratio"] <= 1
assert not any(x["search"]["stepped"] for x in r["transitions"])
rn = json.load(open(t + "/rn.json"))
assert rn["parameters"]["step_feet"] is True
assert any(x["search"]["stepped"] for x in rn["transitions"])
# Stepped transitions skate less than the search's own legs did.
for a, b in zip(rn["transitions"], r["transitions"]):
    if a["search"]["stepped"]:
        assert a["foot_skating_ratio"] < b["foot_skating_ratio"], (a["foot_skating_ratio"], b["foot_skating_ratio"])
# g by its name, the capture beside the transitions.
for tr in r["transitions"]:
    assert tr["g_paper_J"] == tr["g_J"]
    for m in tr["baselines_same_length"].values():
        assert m["g_paper_J"] == m["g_J"]
mo = r["motion"]
assert mo["g_paper_total_J"] == mo["g_total_J"]
# Range violations named, the count kept; contacts per foot segment; the
# sliding / skating pair explained (docs/synthesis.md "Reports").
for tr in r["transitions"]:
    assert len(tr["range_violation_list"]) == tr["range_violations"]
    for v in tr["range_violation_list"]:
        assert v["excess_deg"] > 0 and v["joint"] and v["channel"].endswith("rotation"), v
        assert not v["min_deg"] <= v["value_deg"] <= v["max_deg"], v
    assert 0 <= tr["foot_sliding_slow_m"] <= tr["foot_sliding_m"] + 1e-12
fc = mo["foot_contacts"]
assert fc and all(len(c["states"]) == mo["frames"] == c["frames"] for c in fc), fc
assert any(c["contact_frames"] > 0 for c in fc)
assert "skating" in r["about_measures"]["sliding_and_skating"]
assert mo["w_J"] > 0 and 0 <= mo["no_contact_ratio"] <= 1 and mo["peak_angular_speed_radps"] > 0
for s in segs:
    if s["kind"] == "partial":
        m = s["measures"]
        assert m["frames"] == s["frames"] - 2, (m["frames"], s["frames"])
        assert m["w_J"] >= m["unsupported_J"] >= 0 and m["peak_angular_speed_radps"] > 0
        # The same skating rule as the segment's own ratio.
        assert abs(m["foot_skating_ratio"] - s["foot_skating_ratio"]) < 1e-12, (m, s)
    else:
        assert "measures" not in s
ps = mo["per_step"]
steps = sum(tr["frames"] + 1 for tr in r["transitions"])
assert ps["transitions"]["steps"] == steps
assert abs(ps["transitions"]["w_J"] * steps - sum(tr["w_J"] for tr in r["transitions"])) < 1e-6 * steps
assert ps["transitions"]["peak_angular_speed_radps"] == max(tr["peak_angular_speed_radps"] for tr in r["transitions"])
captured = [s["measures"] for s in segs if s["kind"] == "partial"]
assert ps["captured"]["steps"] == sum(m["frames"] + 1 for m in captured)
assert abs(ps["captured"]["unsupported_J"] * ps["captured"]["steps"] - sum(m["unsupported_J"] for m in captured)) < 1e-6 * ps["captured"]["steps"]
rs = json.load(open(t + "/rs.json"))
assert all(x["method"] == "slerp" for x in rs["transitions"])
rp = json.load(open(t + "/rp.json"))
assert rp["chosen"][0]["rank"] == 2 and rp["chosen"][1]["rank"] == 1
# The BVH frame count matches the report.
frames = [l for l in open(t + "/m.bvh") if l.startswith("Frames:")]
assert int(frames[0].split()[1]) == r["motion"]["frames"]
print("ok")
PY
# Without --results the search engine runs in the process (its rank-1 results).
"$synth" "${base[@]/m.bvh/me.bvh}" --report "$tmp/re.json" >/dev/null
python3 - "$tmp/re.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
assert r["timings_ms"]["search"] > 0
assert [c["rank"] for c in r["chosen"]] == [1, 1]
assert all(c["start_frame"] < c["end_frame"] for c in r["chosen"])
PY
# A timed in-between (docs/queries.md "Timed key poses"): frames 100 and 131
# of a held-out walk at 0 and 31/30 s give 32 frames at the file's rate and
# 63 at --fps 60, the pair warped by default (docs/synthesis.md "Warped
# fills") and not with --no-warp; --fps and --warp are refused for an
# untimed query, --warp with --no-warp, --warp-candidates 0.
walk="$(cd "$data/bandai-namco-1/data" && pwd)/dataset-1_walk_normal_001.bvh"
printf '{"id": "ib", "frames": [{"bvh": "%s", "frame": 100, "time_s": 0}, {"bvh": "%s", "frame": 131, "time_s": 1.0333333}], "filter": {"exclude": ["dataset-1_walk_normal_001*"]}}\n' \
  "$walk" "$walk" >"$tmp/timed.json"
"$synth" --index "$tmp/index.h5" --query "$tmp/timed.json" --out "$tmp/t.bvh" --report "$tmp/t.json" >/dev/null
"$synth" --index "$tmp/index.h5" --query "$tmp/timed.json" --out "$tmp/t60.bvh" --report "$tmp/t60.json" \
  --fps 60 >/dev/null
"$synth" --index "$tmp/index.h5" --query "$tmp/timed.json" --out "$tmp/tn.bvh" --report "$tmp/tn.json" \
  --no-warp >/dev/null
grep -q "^Frames: 32$" "$tmp/t.bvh" || fail "the timed motion does not have 32 frames"
grep -q "^Frames: 32$" "$tmp/tn.bvh" || fail "the unwarped timed motion does not have 32 frames"
grep -q "^Frames: 63$" "$tmp/t60.bvh" || fail "the timed motion at 60 fps does not have 63 frames"
python3 - "$tmp/t.json" "$tmp/t60.json" "$tmp/tn.json" <<'PY'
import json, sys
for path, fps, warped in zip(sys.argv[1:], (30.0, 60.0, 30.0), (True, True, False)):
    r = json.load(open(path))
    t = r["timing"]
    assert abs(t["fps"] - fps) < 1e-3, t
    p = t["pairs"][0]
    assert p["key_frame"] == 0 and not p["direct"], p
    assert 1 + p["in_frames"] + p["partial_frames"] + p["out_frames"] + 1 == r["motion"]["frames"], p
    assert 0.7 < p["warp"] < 1.4, p
    assert p["warped"] == warped, (path, p)
    if warped:
        assert p["in_frames"] == p["out_frames"] <= 1, p  # one 30-fps frame at most
        assert 0 <= p["warp_size_m"] < 0.5 and 1 <= p["warp_candidates"] <= 5, p
    else:
        assert "warp_size_m" not in p and p["in_frames"] > 0, p
PY
expect_error "needs a timed query" "${base[@]/m.bvh/mf.bvh}" --results "$tmp/results.jsonl" --fps 60
expect_error "needs a timed query" "${base[@]/m.bvh/mf.bvh}" --results "$tmp/results.jsonl" --warp
expect_error "excludes" "${base[@]/m.bvh/mf.bvh}" --results "$tmp/results.jsonl" --warp --no-warp
expect_error "warp-candidates" "${base[@]/m.bvh/mf.bvh}" --results "$tmp/results.jsonl" \
  --warp-candidates 0
echo "ok: mocap-synth CLI"
