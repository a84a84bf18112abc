#!/usr/bin/env python3
"""File conversions bench/run_tetmesh.sh needs for TetGen (standard library only).

    tetmesh_io.py obj-to-off IN.obj OUT.off     polygons as triangle fans; texture and normal
                                                indices dropped (TetGen reads no OBJ)
    tetmesh_io.py tetgen-to-msh BASE OUT.msh    BASE.node and BASE.ele as an MSH 2.2 ASCII
                                                tet mesh, in idas's orientation
"""
import sys


def obj_to_off(src, dst):
    v, f = [], []
    for line in open(src, errors="replace"):
        p = line.split()
        if not p:
            continue
        if p[0] == "v":
            v.append(p[1:4])
        elif p[0] == "f":
            idx = [int(x.split("/")[0]) for x in p[1:]]
            idx = [i - 1 if i > 0 else len(v) + i for i in idx]  # negative: relative
            for k in range(1, len(idx) - 1):
                f.append((idx[0], idx[k], idx[k + 1]))
    with open(dst, "w") as out:
        out.write("OFF\n%d %d 0\n" % (len(v), len(f)))
        for p in v:
            out.write(" ".join(p) + "\n")
        for t in f:
            out.write("3 %d %d %d\n" % t)


def numbers(path):
    """The lines of a TetGen file as lists of numbers, comments and blank lines left out."""
    for line in open(path):
        line = line.split("#")[0].split()
        if line:
            yield line


def orient(a, b, c, d):
    """Sign of the determinant of (b - a, c - a, d - a) in doubles: enough to tell which
    convention a mesher writes in (the exact count of inverted tets is idas info's)."""
    u = [b[i] - a[i] for i in range(3)]
    v = [c[i] - a[i] for i in range(3)]
    w = [d[i] - a[i] for i in range(3)]
    det = (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
           u[2] * (v[0] * w[1] - v[1] * w[0]))
    return (det > 0) - (det < 0)


def tetgen_to_msh(base, dst):
    node = numbers(base + ".node")
    n = int(next(node)[0])
    ids, points = {}, []
    for _ in range(n):
        p = next(node)
        ids[int(p[0])] = len(points)
        points.append(tuple(float(x) for x in p[1:4]))
    ele = numbers(base + ".ele")
    m, corners = (int(x) for x in next(ele)[:2])
    if corners != 4:
        raise SystemExit("%s.ele: %d corners per element; only linear tets are read" % (base, corners))
    tets = [[ids[int(x)] for x in next(ele)[1:5]] for _ in range(m)]
    # TetGen lists a tet's corners in the opposite orientation to idas's (positive
    # orient3d); most tets tell which convention this file uses, and all follow it.
    if sum(orient(*(points[i] for i in t)) for t in tets) < 0:
        for t in tets:
            t[2], t[3] = t[3], t[2]
    with open(dst, "w") as out:
        out.write("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n%d\n" % len(points))
        for i, p in enumerate(points):
            out.write("%d %.17g %.17g %.17g\n" % (i + 1, p[0], p[1], p[2]))
        out.write("$EndNodes\n$Elements\n%d\n" % len(tets))
        for k, t in enumerate(tets):
            out.write("%d 4 2 1 1 %d %d %d %d\n" % (k + 1, t[0] + 1, t[1] + 1, t[2] + 1, t[3] + 1))
        out.write("$EndElements\n")


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "obj-to-off":
        obj_to_off(sys.argv[2], sys.argv[3])
    elif len(sys.argv) == 4 and sys.argv[1] == "tetgen-to-msh":
        tetgen_to_msh(sys.argv[2], sys.argv[3])
    else:
        raise SystemExit(__doc__)
