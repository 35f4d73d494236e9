#!/usr/bin/env python3
"""Where a 2D trajectory's steps go wrong: each step between consecutive scans against the truth,
beside the odometry's step of the same log.

A SLAM front end should be at least as good as the odometry from one scan to the next; a step it
gets much worse than the odometry is a registration that slid (into a wrong minimum, or along a
corridor), and a pose graph spreads a loop's correction by the steps' covariances, so one such
step that reported a tight covariance bends the map elsewhere. This lists those steps, for the
hold-out inputs of benchmarks/slam_logs.sh (--keep DIR keeps each run's log, truth and output):

  benchmarks/step_errors.py TRUTH TRAJECTORY LOG [--worst N] [--threshold-deg D]

TRUTH and TRAJECTORY are "timestamp x y theta" lines (as ../shared/tools/noisy_log.py and
examples/03_slam_carmen --out write them), LOG the CARMEN log the trajectory was made from
(FLASER records, plain or .gz; their pose is the odometry). Steps are taken between consecutive
timestamps present in all three. Prints the mean step errors of the trajectory and of the
odometry, how many steps of each are off by more than --threshold-deg (default 3), the --worst
steps (default 10) by rotation error and by translation error, and last one JSON line.
"""
import argparse
import json
import math
import statistics

from relations_consistency import between, read_flaser_odometry, read_trajectory


def step_error(truth_a, truth_b, a, b):
    """(m, deg): how far the step a -> b is from the true step."""
    t, e = between(truth_a, truth_b), between(a, b)
    return (math.hypot(e[0] - t[0], e[1] - t[1]),
            abs(math.degrees(math.remainder(e[2] - t[2], 2 * math.pi))))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('truth')
    ap.add_argument('trajectory')
    ap.add_argument('log')
    ap.add_argument('--worst', type=int, default=10)
    ap.add_argument('--threshold-deg', type=float, default=3.0)
    args = ap.parse_args()
    # Timestamps matched to 0.1 ms, as ../shared/tools/eval_traj.py does.
    key = lambda poses: {round(t, 4): p for t, p in poses.items()}
    truth = key(read_trajectory(args.truth))
    estimate = key(read_trajectory(args.trajectory))
    odometry = key(read_flaser_odometry(args.log))
    stamps = sorted(set(truth) & set(estimate) & set(odometry))
    if len(stamps) < 2:
        raise SystemExit('step_errors.py: fewer than 2 timestamps in all three inputs')
    steps = []
    for i, (a, b) in enumerate(zip(stamps, stamps[1:])):
        em, ed = step_error(truth[a], truth[b], estimate[a], estimate[b])
        om, od = step_error(truth[a], truth[b], odometry[a], odometry[b])
        steps.append((i, a, b, em, ed, om, od))
    n = len(steps)
    mean = lambda k: statistics.mean(s[k] for s in steps)
    print('%d steps: trajectory off %.4f m %.3f deg on average, odometry %.4f m %.3f deg'
          % (n, mean(3), mean(4), mean(5), mean(6)))
    over_estimate = sum(s[4] > args.threshold_deg for s in steps)
    over_odometry = sum(s[6] > args.threshold_deg for s in steps)
    print('steps off by more than %g deg: trajectory %d, odometry %d'
          % (args.threshold_deg, over_estimate, over_odometry))
    for name, k in (('rotation', 4), ('translation', 3)):
        print('worst %d steps by %s error:' % (min(args.worst, n), name))
        for i, a, b, em, ed, om, od in sorted(steps, key=lambda s: -s[k])[:args.worst]:
            t = between(truth[a], truth[b])
            print('  step %d (%.4f -> %.4f), true %.3f m %.2f deg: trajectory off %.3f m %.2f deg,'
                  ' odometry off %.3f m %.2f deg'
                  % (i, a, b, math.hypot(t[0], t[1]), math.degrees(t[2]), em, ed, om, od))
    print(json.dumps({'steps': n, 'trajectory_m': round(mean(3), 4),
                      'trajectory_deg': round(mean(4), 3), 'odometry_m': round(mean(5), 4),
                      'odometry_deg': round(mean(6), 3), 'trajectory_over': over_estimate,
                      'odometry_over': over_odometry}))


if __name__ == '__main__':
    main()
