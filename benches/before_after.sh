#!/usr/bin/env bash
# Criterion before/after of one engine bench in one run: builds `benches/engine.rs` of BASE (a
# commit) in a temporary worktree with its own target directory, and of the working tree, then
# runs the two binaries in turn, ROUNDS times each, so that both see the same machine.
#
#   benches/before_after.sh BASE [FILTER] [ROUNDS]
#   benches/before_after.sh 9676e06 'network/240x180/1%$' 3
#
# Read the least time of each build's rounds; run it on a quiet machine. Both builds keep
# Criterion's data in this checkout's target/, so each "change" line compares a run with the
# other build's run just before it.
set -euo pipefail
base=${1:?usage: before_after.sh BASE [FILTER] [ROUNDS]}
filter=${2:-'network/240x180/1%$'}
rounds=${3:-3}
cd "$(dirname "$0")/.."
before=$(mktemp -d)
trap 'git worktree remove --force "$before"' EXIT
git worktree add --detach --quiet "$before" "$base"

# The path of the engine bench binary that `cargo bench --no-run` builds in directory $1.
bench_binary() {
    (cd "$1" && cargo bench --bench engine --no-run 2>&1) |
        sed -n 's/.*Executable.*(\(.*\)).*/\1/p' | tail -n 1
}
old="$before/$(bench_binary "$before")"
new="$PWD/$(bench_binary .)"
for round in $(seq "$rounds"); do
    for build in before after; do
        if [ "$build" = before ]; then bin=$old; else bin=$new; fi
        echo "== round $round: $build"
        "$bin" --bench "$filter" --noplot --warm-up-time 1 --measurement-time 4 |
            grep -E 'time:|^[^ ]+$'  # a long name stands on its own line above its time
    done
done
