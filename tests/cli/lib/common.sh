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
