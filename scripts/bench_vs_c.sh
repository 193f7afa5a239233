#!/usr/bin/env bash
# Build the C reference of the UNGM bootstrap filter (bench/ungm_ref.c, or the path given)
# and run `pfbench bench` against it in the same run. Usage: scripts/bench_vs_c.sh [ungm_ref.c] [args]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
src=${1:-$here/bench/ungm_ref.c}
shift || true
bin=$(mktemp -d)/ungm_ref
gcc -O3 -march=native -fopenmp -o "$bin" "$src" -lm
exec pfbench bench --c-ref "$bin" "$@"
