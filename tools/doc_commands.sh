#!/usr/bin/env bash
# Runs every `legwise …` command (and `cargo run --release -- …`, run as `legwise …`) of the code
# blocks of README.md and docs/*.md, page by page in the page's order, each page in a fresh
# scratch directory holding the repository's models/, examples/ and tests/data/, with the release
# binary first on the PATH: as a reader who ran `cargo install --path .` types them. Pipelines
# and redirections run as written (bash -c). Comment lines, and output lines of `text` blocks
# (`legwise workspace: …`), are skipped. A command that does not exit 0 is reported with its
# output; the script exits 1 if any did.
#
# Not run by CI (the Monte Carlo studies alone take minutes): tests/it/doc_commands.rs checks in
# CI that every such command parses and names files that exist.
#
# Usage: tools/doc_commands.sh [PAGE.md …]   (default: README.md docs/*.md)
set -uo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
if [[ $# -gt 0 ]]; then pages=("$@"); else pages=("$root/README.md" "$root"/docs/*.md); fi

cargo build --release --quiet --manifest-path "$root/Cargo.toml" || exit 1
bin="${CARGO_TARGET_DIR:-$root/target}/release"
export PATH="$bin:$PATH"

failed=0 count=0
for page in "${pages[@]}"; do
  scratch="$(mktemp -d)"
  cp -r "$root/models" "$root/examples" "$scratch/"
  mkdir -p "$scratch/tests" && cp -r "$root/tests/data" "$scratch/tests/"
  # docs/models.md's walk-through names the reader's new model `m.yaml`: the 5R stands in.
  cp "$root/models/5r.yaml" "$scratch/m.yaml" && cp "$root/models/5r.urdf" "$scratch/"
  mapfile -t lines < <(awk '/^[[:space:]]*```/{inside=!inside; next} inside' "$page" |
    sed -e 's/^[[:space:]]*//' -e 's/cargo run --release -- /legwise /g' |
    grep -E '^legwise [a-z-]+( |$)' | grep -vE '^legwise [a-z]+:')
  for line in "${lines[@]}"; do
    count=$((count + 1))
    start=$SECONDS
    status=0
    (cd "$scratch" && bash -c "$line" >"$scratch/.out" 2>&1) || status=$?
    if [[ $status -ne 0 ]]; then
      failed=$((failed + 1))
      tail -5 "$scratch/.out" >&2
      echo "docs: FAILED (exit $status) ${page#"$root"/}: $line" >&2
    else
      echo "docs: ok in $((SECONDS - start)) s: ${page#"$root"/}: $line"
    fi
  done
  rm -rf "$scratch"
done
echo "docs: $count commands, $failed failed"
[[ $failed -eq 0 ]]
