#!/usr/bin/env bash
# Hold-out evaluation of the 2D SLAM on the four corrected logs of ../shared/data/carmen_corrected:
# each log is turned into a SLAM input with ../shared/tools/noisy_log.py (its real scans, a
# drifting synthetic odometry; seeds 1-3, noise scale 1 and 2), mapped by 03_slam_carmen with its
# defaults, and scored by ../shared/tools/eval_traj.py against the corrected poses.
#
#   benchmarks/slam_logs.sh [BUILD_DIR] [--max-range R] [--beam-step K] [--laps N]
#                           [--seeds "S ..."] [--scales "K ..."] [--keep DIR]
#                           [-- extra 03_slam_carmen flags]                (from the repo root)
#
# --max-range R drops every return farther than R metres from the logs before mapping, as a
# shorter-range scanner would see them (5.6 m: a Hokuyo URG-04LX's maximum range).
# --beam-step K keeps every K-th beam of each scan, as a scanner with K times coarser angular
# resolution would see the same field of view (2: 1 degree instead of 0.5 on the 0.5-degree logs).
# --laps N plays each log N times, every second time backwards: the robot drives its route
# there and back, reversing on the way back (its scanner keeps facing the same way on the
# robot), and every place is revisited N - 1 times.
# --seeds / --scales replace the noise seeds (default "1 2 3") and scales (default "1 2") of
# noisy_log.py, e.g. --seeds "4 5 6" --scales "1 3"; the goals are checked the same way.
# --keep DIR keeps every run's input log, its truth and the SLAM's output in DIR (named
# LOG.SEED.SCALE.log, .truth and a folder), e.g. for tools/loop_closure_audit.
#
# Prints one row per run and the goals of issue 19: loop_m <= 0.10 m, consistency_mm <=
# 1.05 x reference_consistency_mm, no non-finite pose. Needs python3; BUILD_DIR defaults to
# build/release (build the target 03_slam_carmen there first).
set -euo pipefail

build=${1:-build/release}
shift || true
max_range=""
beam_step=1
laps=1
seeds="1 2 3"
scales="1 2"
keep=""
while [[ ${1:-} =~ ^--(max-range|beam-step|laps|seeds|scales|keep)$ ]]; do
  case $1 in
    --max-range) max_range=${2:?--max-range needs a value in metres} ;;
    --beam-step) beam_step=${2:?--beam-step needs a count} ;;
    --laps) laps=${2:?--laps needs a count} ;;
    --seeds) seeds=${2:?--seeds needs a list} ;;
    --scales) scales=${2:?--scales needs a list} ;;
    --keep) keep=${2:?--keep needs a folder} ;;
  esac
  shift 2
done
[[ $beam_step =~ ^[1-9][0-9]*$ ]] || { echo "--beam-step needs a count >= 1" >&2; exit 1; }
[[ ${1:-} == "--" ]] && shift
extra=("$@")
slam="$build/examples/03_slam_carmen"
data=${RANGENAV_DATA_DIR:-../shared/data}
tools=$(dirname "$data")/tools
[[ -x $slam ]] || { echo "no $slam: cmake --build $build --target 03_slam_carmen" >&2; exit 1; }
if [[ -n $keep ]]; then
  mkdir -p "$keep"
  work=$keep
else
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
fi

printf '%-16s %4s %5s %6s %8s %9s %9s %6s %9s %6s %s\n' log seed scale scans loop_m \
  cons_mm ref_mm ratio nonfinite loops scans/s
fail=0
runs=0
for name in csail intel freiburg-101 freiburg-079; do
  src="$data/carmen_corrected/$name-corrected.log.gz"
  [[ -f $src ]] || { echo "missing $src" >&2; exit 1; }
  input=$src
  if ((laps > 1)); then
    # The scans of the log, then the same backwards, and so on: N laps there and back.
    input="$work/$name.laps.log"
    python3 - "$src" "$input" "$laps" <<'EOF'
import gzip, sys
src, out, laps = sys.argv[1], sys.argv[2], int(sys.argv[3])
scans = [line for line in gzip.open(src, "rt") if line.startswith("FLASER ")]
with open(out, "w") as f:
    for lap in range(laps):
        f.writelines(scans if lap % 2 == 0 else scans[::-1])
EOF
  fi
  for scale in $scales; do
    for seed in $seeds; do
      base="$work/$name.$seed.$scale"
      python3 "$tools/noisy_log.py" "$input" "$base.log" "$base.truth" --seed "$seed" \
        --scale "$scale" >/dev/null
      if [[ -n $max_range ]] || ((beam_step > 1)); then
        # FLASER n r_1 .. r_n ...: every beam_step-th reading (the same field of view), and a
        # return beyond max_range becomes no return (0).
        python3 - "$base.log" "${max_range:-inf}" "$beam_step" <<'EOF'
import sys
path, limit, step = sys.argv[1], float(sys.argv[2]), int(sys.argv[3])
lines = []
for line in open(path):
    t = line.split()
    n = int(t[1])
    kept = [r if 0 < float(r) <= limit else "0" for r in t[2:2 + n][::step]]
    lines.append(" ".join([t[0], str(len(kept))] + kept + t[2 + n:]) + "\n")
open(path, "w").writelines(lines)
EOF
      fi
      json=$("$slam" "$base.log" --out "$base" "${extra[@]}" | tail -n 1)
      score=$(python3 "$tools/eval_traj.py" "$base.truth" "$base/trajectory.txt" --log "$base.log")
      row=$(python3 - "$json" "$score" "$name" "$seed" "$scale" <<'EOF'
import json, sys
run, s = json.loads(sys.argv[1]), json.loads(sys.argv[2])
name, seed, scale = sys.argv[3:6]
ratio = s["consistency_mm"] / s["reference_consistency_mm"]
ok = s["loop_m"] <= 0.10 and ratio <= 1.05 and s["nonfinite"] == 0
print("%-16s %4s %5s %6d %8.4f %9.2f %9.2f %6.3f %9d %6d %9.0f %s" % (
    name, seed, scale, run["scans"], s["loop_m"], s["consistency_mm"],
    s["reference_consistency_mm"], ratio, s["nonfinite"], run["loop_closures"],
    run["scans_per_second"], "" if ok else "FAIL"))
EOF
)
      echo "$row"
      runs=$((runs + 1))
      [[ $row == *FAIL ]] && fail=$((fail + 1))
    done
  done
done
echo "runs missing a goal: $fail of $runs"
