#!/usr/bin/env bash
# Build the C reference of the UNGM bootstrap filter (bench/ungm_ref.c, or a .c file given first)
# and run `pfbench bench` against it in the same run; the other arguments go to pfbench bench.
# Usage: scripts/bench_vs_c.sh [ungm_ref.c] [pfbench bench options, e.g. --quick --only ungm]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
src=$here/bench/ungm_ref.c
if [[ $# -gt 0 && $1 == *.c ]]; then
    src=$1
    shift
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
gcc -O3 -march=native -fopenmp -o "$tmp/ungm_ref" "$src" -lm
pfbench bench --c-ref "$tmp/ungm_ref" "$@"
