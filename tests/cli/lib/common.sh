# Sourced by tests/cli/*.sh (this folder is not a test itself).
#
# missing_tool SETUP MESSAGE...: a tool the test needs is absent. Outside CI
# the test is skipped (exit 77, CTest's SKIP_RETURN_CODE); under CI=true it
# fails, since CI must run every test. SETUP names the script that installs it.
missing_tool() {
  local setup="$1"
  shift
  if [ "${CI:-}" = "true" ]; then
    echo "FAIL: $* (CI=true: the test must run; $setup installs it)" >&2
    exit 1
  fi
  echo "SKIP: $* ($setup installs it)"
  exit 77
}

# cli_setup NAME BUILD_DIR DATA_DIR: sets build, data, indexer, search and
# synth, skips (exit 77) without the sample data, makes the temporary folder
# $tmp (removed at exit) and defines fail MESSAGE (exit 1).
cli_setup() {
  local name="$1"
  build="${2:?usage: $name.sh BUILD_DIR DATA_DIR}"
  data="${3:?usage: $name.sh BUILD_DIR DATA_DIR}"
  indexer="$build/indexer/mocap-index"
  search="$build/search/mocap-search"
  synth="$build/synth/mocap-synth"
  [ -d "$data/bandai-namco-1/data" ] || { echo "SKIP: no data at $data"; exit 77; }
  tmp="$(mktemp -d)"
  trap 'rm -rf "$tmp"' EXIT
}
fail() { echo "FAIL: $*" >&2; exit 1; }
