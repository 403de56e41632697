# Sourced by the examples: a local deployment under runs/examples/<name>, stopped on exit.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${DH_BIN_DIR:-build/bin}
[ -x "$bin/dh" ] || { echo "build first: scripts/build" >&2; exit 2; }
dh=$bin/dh
export DH_RUNS_DIR=$PWD/runs/examples/$(basename "$0")
rm -rf "$DH_RUNS_DIR" && mkdir -p "$DH_RUNS_DIR"
$dh launch deploy/campaign_local.yaml > "$DH_RUNS_DIR/launch.log" 2>&1 & launcher=$!
trap 'kill $launcher 2>/dev/null; wait $launcher 2>/dev/null || true' EXIT
say() { printf '\n== %s\n' "$*"; }
