#!/usr/bin/env python3
"""How far a SLAM relations file (Freiburg benchmark format) contradicts itself.

Three relations a->b, b->c and a->c of the same file form a triangle: composing the first two
must give the third. Their disagreement (m) is an error of the reference itself, which no
trajectory can score below. With --trajectory (lines "timestamp x y theta", as written by
examples/03_slam_carmen --out) the trajectory's translational relation errors are also split
into the relations on a triangle inconsistent beyond --threshold and the rest.

With --log (the CARMEN log the relations were made for, FLASER records, plain or .gz), the
short relations (< 2 s) are compared with the log's odometry between the same two scans: the
correction the reference applied to the odometry, its share that is zero, and whether the
corrections lie on a lattice (translation corrections whose norms are h * sqrt(i^2 + j^2) for
integers i, j; yaw corrections offset + k * step). A reference that is the lattice point nearest
the truth is off by up to half a step per axis, so an error-free trajectory scores about
0.383 h on those relations (the mean distance of a uniform point of an h x h square from its
centre). With --trajectory as well, its errors are split into the relations whose translation
is the odometry's and the rest, and on the rest it says where the trajectory lies between the
relation (0 %) and the odometry (100 %).

  benchmarks/relations_consistency.py RELATIONS [--trajectory FILE] [--log LOG] [--threshold M]
                                      [--worst N]
"""
import argparse
import bisect
import collections
import gzip
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


def nearest(poses, times, t, tolerance=math.inf):
    """The pose whose timestamp is nearest t; None when that is farther than tolerance."""
    i = bisect.bisect_left(times, t)
    best = min((j for j in (i - 1, i) if 0 <= j < len(times)), key=lambda j: abs(times[j] - t))
    return poses[times[best]] if abs(times[best] - t) <= tolerance else None


def between(pa, pb):
    """pb in the frame of pa."""
    c, s = math.cos(pa[2]), math.sin(pa[2])
    dx, dy = pb[0] - pa[0], pb[1] - pa[1]
    return (c * dx + s * dy, -s * dx + c * dy, math.remainder(pb[2] - pa[2], 2 * math.pi))


def relation_error(poses, times, a, b, r):
    e = between(nearest(poses, times, float(a)), nearest(poses, times, float(b)))
    return math.hypot(e[0] - r[0], e[1] - r[1])


def read_flaser_odometry(path):
    """{ipc_timestamp: (x, y, theta)} of the FLASER records (the laser's odometry pose)."""
    poses = {}
    with (gzip.open(path, 'rt') if path.endswith('.gz') else open(path)) as f:
        for line in f:
            v = line.split()
            if len(v) < 2 or v[0] != 'FLASER':
                continue
            n = int(v[1])
            if len(v) >= n + 9:
                poses[float(v[n + 8])] = tuple(map(float, v[n + 2:n + 5]))
    return poses


# The mean distance of a uniform point of a unit square from its centre, (sqrt(2) + asinh(1)) / 6.
SQUARE_MEAN_DISTANCE = (math.sqrt(2) + math.asinh(1)) / 6


def on_lattice(value, step, offset=0.0, tolerance=0.02):
    k = (value - offset) / step
    return abs(k - round(k)) < tolerance


def on_square_lattice(norm, h, tolerance=0.04):
    """Is norm the length of a vector (i h, j h) for integers i, j?"""
    n2 = (norm / h) ** 2
    if abs(n2 - round(n2)) >= tolerance:
        return False
    n = round(n2)
    return any(math.isqrt(n - i * i) ** 2 == n - i * i for i in range(math.isqrt(n) + 1))


def odometry_corrections(rel, odometry):
    """The short relations against the log's odometry (see the module's docstring)."""
    times = sorted(odometry)
    found = []
    for a, b, r in rel:
        ta, tb = float(a), float(b)
        pa, pb = nearest(odometry, times, ta, 1e-3), nearest(odometry, times, tb, 1e-3)
        if tb - ta >= 2 or pa is None or pb is None:
            continue
        o = between(pa, pb)
        found.append((a, b, r, math.hypot(r[0] - o[0], r[1] - o[1]),
                      math.remainder(r[2] - o[2], 2 * math.pi), o))
    if not found:
        print('no short relation has both timestamps in the log')
        return {}, set()
    equal = [f for f in found if f[3] < 1e-4]
    moved = [f[3] for f in found if f[3] >= 1e-4]
    print('%d short relations against the log\'s odometry: %d with its translation (within 0.1 mm)'
          % (len(found), len(equal)))
    if moved:
        norms = collections.Counter(round(d, 3) for d in moved)
        print('  translation corrections (m: count): ' +
              ', '.join('%.3f: %d' % kv for kv in sorted(norms.items())[:12]))
        h = norms.most_common(1)[0][0]  # the lattice's step is its most common norm
        lattice = sum(on_square_lattice(d, h) for d in moved)
        print('  %d of %d corrections on the lattice of h = %.4f m (norm = h sqrt(i^2 + j^2)). If '
              'the reference is the lattice point nearest the truth, an error-free trajectory '
              'scores about %.4f m on these %d relations'
              % (lattice, len(moved), h, SQUARE_MEAN_DISTANCE * h, len(found)))
    yaws = sorted(f[4] for f in found)
    gaps = [q - p for p, q in zip(yaws, yaws[1:]) if q - p > 1e-4]
    if gaps:
        step = collections.Counter(round(g, 5) for g in gaps).most_common(1)[0][0]
        # The lattice's offset: the circular mean of the yaws' phases within a step.
        phase = [2 * math.pi * y / step for y in yaws]
        offset = step / (2 * math.pi) * math.atan2(sum(map(math.sin, phase)),
                                                   sum(map(math.cos, phase)))
        for reach in (4, 16, 64, math.inf):  # refine the step on ever farther lattice points
            near = [(round((y - offset) / step), y - offset) for y in yaws
                    if abs(y - offset) < reach * step]
            if sum(k * k for k, _ in near) > 0:
                step = sum(k * d for k, d in near) / sum(k * k for k, _ in near)
        lattice = sum(on_lattice(y, step, offset) for y in yaws)
        print('  yaw corrections: %d of %d on offset %.4f + k * %.5f rad (%.3f deg); the nearest '
              'lattice point is off by %.3f deg on average'
              % (lattice, len(yaws), offset, step, math.degrees(step), math.degrees(step) / 4))
    return {(f[0], f[1]): f[5] for f in found}, {(f[0], f[1]) for f in equal}


def share_towards(poses, times, a, b, r, o):
    """Where the trajectory's translation lies between the relation's r (0) and the odometry's o
    (1): its projection on the segment from r to o, as a fraction of the segment's length."""
    e = between(nearest(poses, times, float(a)), nearest(poses, times, float(b)))
    d = (o[0] - r[0], o[1] - r[1])
    return ((e[0] - r[0]) * d[0] + (e[1] - r[1]) * d[1]) / (d[0] ** 2 + d[1] ** 2)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('relations')
    ap.add_argument('--trajectory')
    ap.add_argument('--log', help='CARMEN log of the relations (FLASER records)')
    ap.add_argument('--threshold', type=float, default=0.08, help='m (default 0.08)')
    ap.add_argument('--worst', type=int, default=5)
    args = ap.parse_args()
    rel = read_relations(args.relations)
    poses = read_trajectory(args.trajectory) if args.trajectory else None
    times = sorted(poses) if poses else []
    if args.log:
        found, equal = odometry_corrections(rel, read_flaser_odometry(args.log))
        if poses:
            groups = {True: [], False: []}
            shares = []
            for a, b, r in rel:
                if (a, b) in found:
                    groups[(a, b) in equal].append(relation_error(poses, times, a, b, r))
                    if (a, b) not in equal:
                        shares.append(share_towards(poses, times, a, b, r, found[(a, b)]))
            for k, name in ((True, 'the odometry\'s translation'), (False, 'a corrected one')):
                if groups[k]:
                    print('  trajectory on the short relations with %s: %d, mean error %.4f m'
                          % (name, len(groups[k]), statistics.mean(groups[k])))
            if shares:
                print('  on the corrected ones the trajectory lies on average %.0f %% of the way '
                      'from the relation towards the odometry' % (100 * statistics.mean(shares)))
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
