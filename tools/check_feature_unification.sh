#!/usr/bin/env bash
# Fails when `cargo test --workspace --release` would build the host or the core with other
# dependency features than `cargo run --release` does: the README's two commands would then build
# both crates twice (about four minutes of a cold CI run). Fix it in host/Cargo.toml by naming the
# feature the new dev-dependency turns on (see the "Feature unification only" dependencies there).
set -euo pipefail
cd "$(dirname "$0")/.."
features() { cargo tree "$@" -f '{p} {f}' --prefix none | sed 's/ (\*)$//' | sort -u; }
run=$(features -p fringe3d -e normal,build)
test=$(features --workspace -e normal,build,dev)
# Every package the main command builds must have the same features in the test build.
missing=$(comm -23 <(echo "$run") <(echo "$test"))
if [ -n "$missing" ]; then
  echo "error: these packages get other features under 'cargo test --workspace --release':" >&2
  echo "$missing" | sed 's/^/  run: /' >&2
  exit 1
fi
echo "feature sets unified: the main command's $(echo "$run" | wc -l) packages build once"
