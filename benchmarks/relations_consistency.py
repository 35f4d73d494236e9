#!/usr/bin/env python3
"""How far a SLAM relations file (Freiburg benchmark format) contradicts itself.

Three relations a->b, b->c and a->c of the same file form a triangle: composing the first two
must give the third. Their disagreement (m) is an error of the reference itself, which no
trajectory can score below. With --trajectory (lines "timestamp x y theta", as written by
examples/03_slam_carmen --out) the trajectory's translational relation errors are also split
into the relations on a triangle inconsistent beyond --threshold and the rest.

  benchmarks/relations_consistency.py RELATIONS [--trajectory FILE] [--threshold M] [--worst N]
"""
import argparse
import bisect
import math
import statistics


def compose(p, q):
    c, s = math.cos(p[2]), math.sin(p[2])
    return (p[0] + c * q[0] - s * q[1], p[1] + s * q[0] + c * q[1], p[2] + q[2])


def read_relations(path):
    """[(timestamp1, timestamp2, (x, y, yaw))], timestamps as written (they are the keys)."""
    rel = []
    with open(path) as f:
        for line in f:
            v = line.split()
            if v and not v[0].startswith('#'):
                rel.append((v[0], v[1], (float(v[2]), float(v[3]), float(v[7]))))
    return rel


def read_trajectory(path):
    poses = {}
    with open(path) as f:
        for line in f:
            v = line.split()
            if len(v) >= 4 and not v[0].startswith('#'):
                poses[float(v[0])] = tuple(map(float, v[1:4]))
    return poses


def nearest(poses, times, t):
    i = bisect.bisect_left(times, t)
    best = min((j for j in (i - 1, i) if 0 <= j < len(times)), key=lambda j: abs(times[j] - t))
    return poses[times[best]]


def relation_error(poses, times, a, b, r):
    pa, pb = nearest(poses, times, float(a)), nearest(poses, times, float(b))
    c, s = math.cos(pa[2]), math.sin(pa[2])
    dx, dy = pb[0] - pa[0], pb[1] - pa[1]
    return math.hypot(c * dx + s * dy - r[0], -s * dx + c * dy - r[1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('relations')
    ap.add_argument('--trajectory')
    ap.add_argument('--threshold', type=float, default=0.08, help='m (default 0.08)')
    ap.add_argument('--worst', type=int, default=5)
    args = ap.parse_args()
    rel = read_relations(args.relations)
    lookup = {(a, b): r for a, b, r in rel}
    out = {}
    for a, b in lookup:
        out.setdefault(a, []).append(b)
    triangles = []
    for (a, c), r in lookup.items():
        for b in out[a]:
            if b != c and (b, c) in lookup:
                p = compose(lookup[(a, b)], lookup[(b, c)])
                triangles.append((math.hypot(p[0] - r[0], p[1] - r[1]), a, b, c))
    triangles.sort(reverse=True)
    if not triangles:
        print('%d relations, no triangles' % len(rel))
        return
    print('%d relations, %d triangles: inconsistency median %.4f m, max %.4f m' %
          (len(rel), len(triangles), statistics.median(t[0] for t in triangles), triangles[0][0]))
    for e, a, b, c in triangles[:args.worst]:
        print('  %.3f m  timestamps %s %s %s' % (e, a, b, c))
    if not args.trajectory:
        return
    poses = read_trajectory(args.trajectory)
    times = sorted(poses)
    flagged = set()
    for e, a, b, c in triangles:
        if e > args.threshold:
            flagged.update({(a, b), (b, c), (a, c)})
    groups = {}
    for a, b, r in rel:
        kind = 'long' if float(b) - float(a) >= 2 else 'short'
        on = 'on' if (a, b) in flagged else 'off'
        groups.setdefault((kind, on), []).append(relation_error(poses, times, a, b, r))
    for (kind, on), errs in sorted(groups.items()):
        where = 'on a triangle inconsistent by > %.2f m' % args.threshold if on == 'on' else 'elsewhere'
        print('%-5s relations %s: %d, mean error %.4f m' % (kind, where, len(errs), statistics.mean(errs)))


if __name__ == '__main__':
    main()
