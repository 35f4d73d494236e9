#!/usr/bin/env bash
# Fuzzes the harnesses of a fuzzer build for a fixed time each; exits non-zero on any finding.
#
#   tests/fuzz/run.sh BUILD_DIR SECONDS [HARNESS...]
#
# BUILD_DIR was configured with RANGENAV_BUILD_FUZZERS=ON (e.g. the `sanitize` preset) and built
# (targets fuzz_<harness> and fuzz_seeds). Without HARNESS names every fuzz_* executable runs.
# Each harness grows its own corpus in BUILD_DIR/tests/fuzz/corpus/<harness>/ (seeded from
# seeds/<harness>/); a finding (crash-*, leak-*, timeout-*, oom-*) lands in
# BUILD_DIR/tests/fuzz/findings/<harness>/ and its log in findings/<harness>.log. FUZZ_JOBS
# harnesses run at once (default 1). One summary line per harness: executions, coverage.
set -euo pipefail
if (($# < 2)); then
  echo "usage: $0 BUILD_DIR SECONDS [HARNESS...]" >&2
  exit 2
fi
fuzz_dir=$(cd "$1/tests/fuzz" && pwd)
seconds=$2
shift 2
names=("$@")
if ((${#names[@]} == 0)); then
  for exe in "$fuzz_dir"/fuzz_*; do
    name=${exe##*/fuzz_}
    [[ -x $exe && $name != make_seeds ]] && names+=("$name")
  done
fi

run_one() {
  local name=$1 fuzz_dir=$2 seconds=$3
  local corpus=$fuzz_dir/corpus/$name findings=$fuzz_dir/findings/$name
  mkdir -p "$corpus" "$findings"
  local log=$fuzz_dir/findings/$name.log
  local rc=0
  # -timeout: one input may take 10 s at most (sanitizers included); -rss_limit_mb: a reader
  # must stay within 2 GB, which also bounds any single allocation (-malloc_limit_mb).
  "$fuzz_dir/fuzz_$name" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix="$findings/" "$corpus" "$fuzz_dir/seeds/$name" \
    >"$log" 2>&1 || rc=$?
  local done_line execs
  done_line=$(grep -E '^#[0-9]+[[:space:]]+DONE' "$log" | tail -1 || true)
  execs=$(grep -E '^stat::number_of_executed_units' "$log" | awk '{print $2}' || true)
  if ((rc != 0)); then
    echo "fuzz_$name: FINDING (exit $rc), see $log and $findings/:"
    grep -E 'ERROR|runtime error|SUMMARY|deadly signal|Test unit written' "$log" | head -20
    return 1
  fi
  printf 'fuzz_%s: %ss clean, %s executions, %s\n' "$name" "$seconds" "${execs:-?}" \
    "$(sed -E 's/^#[0-9]+[[:space:]]+DONE[[:space:]]+//' <<<"$done_line")"
}
export -f run_one

status=0
printf '%s\n' "${names[@]}" |
  xargs -P "${FUZZ_JOBS:-1}" -I{} bash -c 'run_one "$@"' _ {} "$fuzz_dir" "$seconds" || status=$?
exit "$status"
