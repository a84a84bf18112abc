#!/usr/bin/env python3
"""Writes seeded triangle soups for bench/run_tetmesh.sh: inputs a tet mesher of soups must
take that a surface mesher would refuse. The same seed gives the same bytes.

    make_soups.py OUT_DIR [--seeds 1 2] [--shards-level 4]

Per seed, three OBJ files:
  spheres_S.obj    six to eight icospheres that overlap (closed, intersecting components:
                   the solid is their union)
  open_boxes_S.obj five rotated boxes that overlap, each with a few faces removed (holes the
                   winding number has to bridge)
  shards_S.obj     an icosphere whose triangles each own their corners, moved apart by up to
                   a quarter of an edge (no shared vertex: gaps and overlaps everywhere);
                   --shards-level subdivisions of the icosahedron (4: 5,120 shards; 1: 80)
"""
import argparse
import math
import os
import random


def icosphere(levels):
    t = (1 + math.sqrt(5)) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
         (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [tuple(c / math.sqrt(1 + t * t) for c in p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(levels):
        mid = {}

        def middle(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                p = [(x + y) / 2 for x, y in zip(v[a], v[b])]
                n = math.sqrt(sum(c * c for c in p))
                v.append(tuple(c / n for c in p))
                mid[key] = len(v) - 1
            return mid[key]

        g = []
        for a, b, c in f:
            ab, bc, ca = middle(a, b), middle(b, c), middle(c, a)
            g += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = g
    return v, f


def rotation(rng):
    """A uniformly random rotation (from a random unit quaternion)."""
    u1, u2, u3 = rng.random(), rng.random(), rng.random()
    w = math.sqrt(1 - u1) * math.sin(2 * math.pi * u2)
    x = math.sqrt(1 - u1) * math.cos(2 * math.pi * u2)
    y = math.sqrt(u1) * math.sin(2 * math.pi * u3)
    z = math.sqrt(u1) * math.cos(2 * math.pi * u3)
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def transform(points, R, scale, offset):
    """Each point scaled axis by axis, rotated by R, then moved by offset."""
    return [tuple(sum(R[i][k] * p[k] * scale[k] for k in range(3)) + offset[i] for i in range(3))
            for p in points]


def box(n):
    """A unit cube [-1, 1]^3, each side an n x n grid of squares cut into two triangles,
    outward."""
    v, f, index = [], [], {}

    def vertex(p):
        key = tuple(round(c * n) for c in p)
        if key not in index:
            index[key] = len(v)
            v.append(p)
        return index[key]

    for axis in range(3):
        for side in (-1, 1):
            u, w = (axis + 1) % 3, (axis + 2) % 3
            for i in range(n):
                for j in range(n):
                    quad = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        p = [0.0, 0.0, 0.0]
                        p[axis] = side
                        p[u] = -1 + 2 * (i + di) / n
                        p[w] = -1 + 2 * (j + dj) / n
                        quad.append(vertex(tuple(p)))
                    a, b, c, d = quad
                    if side > 0:
                        f += [(a, b, c), (a, c, d)]
                    else:
                        f += [(a, c, b), (a, d, c)]
    return v, f


def write_obj(path, parts):
    with open(path, "w") as out:
        base = 1
        for v, f in parts:
            for p in v:
                out.write("v %.17g %.17g %.17g\n" % p)
            for t in f:
                out.write("f %d %d %d\n" % tuple(base + i for i in t))
            base += len(v)


def spheres(rng):
    parts = []
    v0, f0 = icosphere(3)
    for _ in range(rng.randint(6, 8)):
        r = rng.uniform(0.3, 0.6)
        c = [rng.uniform(-0.5, 0.5) for _ in range(3)]
        parts.append((transform(v0, rotation(rng), [r, r, r], c), f0))
    return parts


def open_boxes(rng):
    parts = []
    v0, f0 = box(6)
    for _ in range(5):
        s = [rng.uniform(0.2, 0.6) for _ in range(3)]
        c = [rng.uniform(-0.4, 0.4) for _ in range(3)]
        f = list(f0)
        for _ in range(rng.randint(1, 4)):
            f.pop(rng.randrange(len(f)))
        parts.append((transform(v0, rotation(rng), s, c), f))
    return parts


def shards(rng, levels=4):
    v0, f0 = icosphere(levels)
    edge = 2 * math.sin(math.atan(2) / 2) / 2**levels  # an icosphere edge, `levels` down
    v, f = [], []
    for t in f0:
        d = [rng.uniform(-0.25, 0.25) * edge for _ in range(3)]
        for i in t:
            v.append(tuple(v0[i][k] + d[k] for k in range(3)))
        f.append((len(v) - 3, len(v) - 2, len(v) - 1))
    return [(v, f)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--shards-level", type=int, default=4)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    for seed in a.seeds:
        for name, make in (("spheres", spheres), ("open_boxes", open_boxes),
                           ("shards", lambda rng: shards(rng, a.shards_level))):
            rng = random.Random("%s-%d" % (name, seed))
            path = os.path.join(a.out, "%s_%d.obj" % (name, seed))
            write_obj(path, make(rng))
            print(path)


if __name__ == "__main__":
    main()
