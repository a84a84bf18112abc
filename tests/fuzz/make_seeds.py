#!/usr/bin/env python3
"""Writes the generated seed inputs of tests/fuzz/corpus/<target>/seed_* (small valid files
in every variant, plus slightly broken ones). Run from anywhere; regression inputs found
by fuzzing (crash_* files) are committed separately and left alone."""
import pathlib
import struct

ROOT = pathlib.Path(__file__).resolve().parent / "corpus"
DATA = pathlib.Path(__file__).resolve().parents[2] / "data"

# Two tetrahedra sharing a face: 5 points, 2 tets, 6 boundary triangles.
P = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1)]
TETS = [(0, 1, 2, 3), (1, 2, 3, 4)]
TRIS = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 4), (1, 4, 3), (2, 3, 4)]


def put(target, name, data):
    d = ROOT / target
    d.mkdir(parents=True, exist_ok=True)
    (d / f"seed_{name}").write_bytes(data.encode() if isinstance(data, str) else data)


def obj():
    v = "".join(f"v {x} {y} {z}\n" for x, y, z in P)
    f = "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in TRIS)
    put("obj", "tris.obj", "# two tets' surface\no mesh\n" + v + f)
    put("obj", "corners.obj", "mtllib a.mtl\n" + v + "vt 0 0\nvn 0 0 1\ng g\nusemtl m\n"
        "f 1/1 2/1 3/1\nf 1//1 2//1 4//1\nf -5/1/1 -3/1/1 -2/1/1 -1/1/1\ns off\n")
    put("obj", "forward.obj", "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n")
    put("obj", "quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\r\nf 1 2 3 4\r\n")
    put("obj", "bad_index.obj", v + "f 1 2 9\n")
    put("obj", "nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    put("obj", "bunny_head.obj", b"".join((DATA / "bunny.obj").read_bytes().splitlines(True)[:60]))


def off():
    v = "".join(f"{x} {y} {z}\n" for x, y, z in P)
    f = "".join(f"3 {a} {b} {c}\n" for a, b, c in TRIS)
    put("off", "tris.off", f"OFF\n{len(P)} {len(TRIS)} 0\n" + v + f)
    put("off", "coff.off", f"# comment\nCOFF {len(P)} 2\n"
        + "".join(f"{x} {y} {z} 255 0 0 255\n" for x, y, z in P)
        + "4 0 1 4 2 1 0 0\n3 0 1 3 # colourless\n")
    put("off", "stcnoff.off", f"STCNOFF\n{len(P)} 3 0\n"
        + "".join(f"{x} {y} {z} 0 0 1 0.5 0.25 1 1 {x} {y}\n" for x, y, z in P)
        + "4 0 1 4 2 0.1 0.2 0.3\n3 0 1 3\n3 1 2 3 7 7 7\n")
    put("off", "colour_index.off", f"NOFF {len(P)} 1\n"
        + "".join(f"{x} {y} {z} 0 1 0\n" for x, y, z in P) + "3 0 1 2 5\n")
    put("off", "edge_with_four_triangles.off", (DATA / "edge_with_four_triangles.off").read_bytes())
    put("off", "lying_counts.off", "OFF\n99999999999 2\n0 0 0\n")
    put("off", "hour_glass_head.off",
        b"".join((DATA / "hour_glass.off").read_bytes().splitlines(True)[:40]))


PLY_TYPES = {"char": "b", "uchar": "B", "short": "h", "ushort": "H", "int": "i", "uint": "I",
             "float": "f", "double": "d"}


def ply_header(fmt, vtype="double", itype="int", extra=""):
    return (f"ply\nformat {fmt} 1.0\ncomment seed\n{extra}element vertex {len(P)}\n"
            f"property {vtype} x\nproperty {vtype} y\nproperty {vtype} z\n"
            f"property uchar red\nelement face {len(TRIS)}\n"
            f"property list uchar {itype} vertex_indices\nproperty float quality\n"
            f"element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n")


def ply():
    body = "".join(f"{x} {y} {z} 7\n" for x, y, z in P)
    body += "".join(f"3 {a} {b} {c} 0.5\n" for a, b, c in TRIS) + "0 1\n"
    put("ply_ascii", "tris.ply", ply_header("ascii") + body)
    put("ply_ascii", "quad_first.ply", "ply\nformat ascii 1.0\nelement info 1\nproperty list uchar "
        "float vals\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar uint vertex_index\nend_header\n2 1 2\n"
        "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n")
    put("ply_ascii", "truncated.ply", ply_header("ascii") + body[:40])
    for order, fmt in (("<", "binary_little_endian"), (">", "binary_big_endian")):
        for vtype, itype in (("double", "int"), ("float", "uint"), ("short", "uchar")):
            b = b"".join(struct.pack(order + PLY_TYPES[vtype] * 3 + "B", x, y, z, 7)
                         for x, y, z in P)
            b += b"".join(struct.pack(order + "B" + PLY_TYPES[itype] * 3 + "f", 3, *t, 0.5)
                          for t in TRIS)
            b += struct.pack(order + "ii", 0, 1)
            put("ply_binary", f"{fmt}_{vtype}_{itype}.ply", ply_header(fmt, vtype, itype).encode() + b)
    put("ply_binary", "truncated.ply", ply_header("binary_little_endian").encode() + b"\0" * 30)


def stl():
    def facets(tris):
        out = "solid seed\n"
        for t in tris:
            out += "  facet normal 0 0 1\n    outer loop\n"
            out += "".join("      vertex %g %g %g\n" % P[i] for i in t)
            out += "    endloop\n  endfacet\n"
        return out + "endsolid seed\n"
    put("stl_ascii", "tris.stl", facets(TRIS))
    put("stl_ascii", "two_solids.stl", facets(TRIS[:2]) + facets(TRIS[2:]).upper())
    put("stl_ascii", "quad.stl", "solid q\nfacet normal nan 0 0\nouter loop\nvertex 0 0 0\n"
        "vertex 1 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid q\n")
    put("stl_ascii", "truncated.stl", facets(TRIS)[:150])

    def binary(header, tris):
        b = header.ljust(80, b" ") + struct.pack("<I", len(tris))
        for t in tris:
            b += struct.pack("<3f", 0, 0, 1)
            for i in t:
                b += struct.pack("<3f", *P[i])
            b += b"\0\0"
        return b
    put("stl_binary", "tris.stl", binary(b"binary seed", TRIS))
    put("stl_binary", "solid_header.stl", binary(b"solid but binary", TRIS[:3]))
    put("stl_binary", "lying_count.stl", binary(b"seed", TRIS)[:-50])
    put("stl_binary", "empty.stl", binary(b"seed", []))


def msh22():
    other = ["1 15 2 0 1 1", "2 1 2 0 1 1 2", "3 2 2 0 1 1 2 3"]
    tets = [f"{4 + k} 4 2 0 1 " + " ".join(str(10 + i) for i in t) for k, t in enumerate(TETS)]
    nodes = "".join(f"{10 + i} {x} {y} {z}\n" for i, (x, y, z) in enumerate(P))
    els = other + tets
    text = ("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n3 1 \"v\"\n"
            "$EndPhysicalNames\n$Nodes\n" + f"{len(P)}\n" + nodes + "$EndNodes\n$Elements\n"
            + f"{len(els)}\n" + "\n".join(els) + "\n$EndElements\n")
    put("msh22_ascii", "tets.msh", text)
    put("msh22_ascii", "missing_node.msh", text.replace("14 1 1 1", "15 1 1 1"))

    b = b"$MeshFormat\n2.2 1 8\n" + struct.pack("<i", 1) + b"\n$EndMeshFormat\n$Nodes\n"
    b += f"{len(P)}\n".encode()
    b += b"".join(struct.pack("<i3d", 10 + i, *p) for i, p in enumerate(P))
    b += b"\n$EndNodes\n$Elements\n" + f"{3 + len(TETS)}\n".encode()
    b += struct.pack("<3i", 15, 1, 2) + struct.pack("<4i", 1, 0, 1, 10)
    b += struct.pack("<3i", 2, 2, 2) + struct.pack("<6i", 2, 0, 1, 10, 11, 12) \
        + struct.pack("<6i", 3, 0, 1, 11, 12, 13)
    b += struct.pack("<3i", 4, len(TETS), 2)
    for k, t in enumerate(TETS):
        b += struct.pack("<7i", 4 + k, 0, 1, *(10 + i for i in t))
    b += b"\n$EndElements\n"
    put("msh22_binary", "tets.msh", b)
    big = b.replace(struct.pack("<i", 1), struct.pack(">i", 1), 1)
    put("msh22_binary", "swapped_marker.msh", big)


def msh41():
    n, m = len(P), len(TETS)
    text = ("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 0 1\n"
            "1 0 0 0 1 1 1 0 0\n$EndEntities\n"
            f"$Nodes\n2 {n} 10 {9 + n}\n3 1 0 3\n10\n11\n12\n0 0 0\n1 0 0\n0 1 0\n"
            f"2 1 1 {n - 3}\n13\n14\n0 0 1 0.5 0.5\n1 1 1 0.5 0.5\n$EndNodes\n"
            f"$Elements\n2 {m + 1} 1 {m + 1}\n2 1 2 1\n1 10 11 12\n3 1 4 {m}\n"
            + "".join(f"{2 + k} " + " ".join(str(10 + i) for i in t) + "\n"
                      for k, t in enumerate(TETS))
            + "$EndElements\n")
    put("msh41_ascii", "tets.msh", text)
    put("msh41_ascii", "lying_total.msh", text.replace(f"$Nodes\n2 {n}", "$Nodes\n2 999999999999"))

    def q(*v):
        return struct.pack(f"<{len(v)}Q", *v)
    b = b"$MeshFormat\n4.1 1 8\n" + struct.pack("<i", 1) + b"\n$EndMeshFormat\n$Entities\n"
    b += q(0, 0, 0, 1) + struct.pack("<i6d", 1, 0, 0, 0, 1, 1, 1) + q(0, 0)
    b += b"\n$EndEntities\n$Nodes\n" + q(1, n, 10, 9 + n)
    b += struct.pack("<3i", 3, 1, 0) + q(n) + q(*range(10, 10 + n))
    b += b"".join(struct.pack("<3d", *p) for p in P)
    b += b"\n$EndNodes\n$Elements\n" + q(2, m + 1, 1, m + 1)
    b += struct.pack("<3i", 2, 1, 2) + q(1) + q(1, 10, 11, 12)
    b += struct.pack("<3i", 3, 1, 4) + q(m)
    for k, t in enumerate(TETS):
        b += q(2 + k, *(10 + i for i in t))
    b += b"\n$EndElements\n"
    put("msh41_binary", "tets.msh", b)
    put("msh41_binary", "truncated.msh", b[:-40])


def points():
    put("points_xyz", "points.xyz", "# x y z nx ny nz\n" + "".join(
        f"{x} {y} {z} 0 0 1\n" for x, y, z in P) + "\n1e-320 -0 +2.5\n")
    put("points_xyz", "bad.xyz", "0 0 0\n1 inf 0\n")
    put("points_ply", "ascii.ply", ply_header("ascii").replace("element face 6", "element face 0")
        .split("element edge")[0] + "end_header\n" + "".join(f"{x} {y} {z} 7\n" for x, y, z in P))
    put("points_ply", "extra_first.ply", "ply\nformat ascii 1.0\nelement camera 2\nproperty float f\n"
        "element vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
        "1\n2\n0 0 0\n1 1 1\n")
    hdr = ("ply\nformat binary_little_endian 1.0\nelement camera 1\nproperty int id\n"
           "element vertex 100\nproperty double x\nproperty double y\nproperty double z\n"
           "element face 1\nproperty list uchar int vertex_indices\nend_header\n")
    put("points_ply", "gaussian_head.ply", hdr.encode() + struct.pack("<i", 3)
        + (DATA / "gaussian_points_100k.ply").read_bytes()[232:232 + 2400])


def gmsh_heads():
    # The first few KB of files Gmsh wrote (tests/data), cut mid-section.
    tests_data = DATA.parent / "tests" / "data"
    for target, name in (("msh22_ascii", "22_ascii"), ("msh22_binary", "22_binary"),
                         ("msh41_ascii", "41_ascii"), ("msh41_binary", "41_binary")):
        put(target, f"gmsh_head_{name}.msh",
            (tests_data / f"gmsh_sphere_{name}.msh").read_bytes()[:3000])


for make in (gmsh_heads, obj, off, ply, stl, msh22, msh41, points):
    make()


# ---- the attributes the readers keep (texture coordinates, normals, colours, tags, fields)

def obj_attributes():
    put("obj", "attributes.obj", "mtllib a.mtl b.mtl\no parts\n"
        "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nv 0 0 1 0.5 0.5 0.5\nv 1 1 1\n"
        "vt 0 0\nvt 1 0\nvt 0 1 0.5\nvn 0 0 1\nvn 1 0 0\n"
        "g left side\nusemtl red\nf 1/1/1 2/2/1 3/3/1\nf 1//2 2//2 4//2\n"
        "g right\nusemtl blue\nf -5/-3 -2/-2 -3/-1\nusemtl red\nf 2/1/2 5/2/2 3/3/2 4/1/1\n"
        "g left side\nf 3 4 5\ns 1\n")
    # Stretch boundaries fall inside these lines when the harness splits the text in three.
    lines = ["v %d %d %d" % p for p in P] + ["vt 0.25 0.75", "vn 0 1 0", "usemtl m1"]
    lines += ["f %d/1/1 %d/1/1 %d/1/1" % tuple(i + 1 for i in t) for t in TRIS[:3]]
    lines += ["g g2", "usemtl m2"] + ["f %d %d %d" % tuple(i - 5 for i in t) for t in TRIS[3:]]
    put("obj", "split_tags.obj", "\n".join(lines) + "\n")
    put("obj", "forward_uv.obj", "f 1/2/1 2/1/1 3/2/1\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\n"
        "vt 1 1\nvn 0 0 1\n")


PLY_ALL = ["char", "uchar", "short", "ushort", "int", "uint", "float", "double",
           "int8", "uint8", "int16", "uint16", "int32", "uint32", "float32", "float64"]
PLY_ALIAS = {"int8": "char", "uint8": "uchar", "int16": "short", "uint16": "ushort",
             "int32": "int", "uint32": "uint", "float32": "float", "float64": "double"}


def ply_attributes():
    vprops = "".join(f"property {t} a_{t}\n" for t in PLY_ALL)
    hdr = lambda fmt: (f"ply\nformat {fmt} 1.0\nelement vertex 4\nproperty float x\n"
                       "property float y\nproperty float z\nproperty float nx\nproperty float ny\n"
                       "property float nz\nproperty uchar red\nproperty uchar green\n"
                       "property uchar blue\nproperty uchar alpha\n" + vprops +
                       "element face 2\nproperty list uchar int vertex_indices\n"
                       "property list uchar float texcoord\nproperty int material\n"
                       "property ushort flags\nproperty double quality\nend_header\n")
    pts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    vals = [-7, 200, -300, 60000, -70000, 4000000000, 0.5, 0.25] * 2
    faces = [((0, 1, 2), 3), ((0, 2, 3, 1), 7)]
    text = ""
    for k, p in enumerate(pts):
        text += " ".join(map(str, p)) + " 0 0 1 255 %d 0 255 " % (k * 60) + \
            " ".join(map(str, vals)) + "\n"
    for f, m in faces:
        tc = [c * 0.25 for c in range(2 * len(f))]
        text += f"{len(f)} " + " ".join(map(str, f)) + f" {len(tc)} " + \
            " ".join(map(str, tc)) + f" {m} 1 0.5\n"
    put("ply_ascii", "attributes.ply", hdr("ascii") + text)
    for order, fmt in (("<", "binary_little_endian"), (">", "binary_big_endian")):
        codes = "".join(PLY_TYPES[PLY_ALIAS.get(t, t)] for t in PLY_ALL)
        b = b""
        for k, p in enumerate(pts):
            b += struct.pack(order + "6f4B", *p, 0, 0, 1, 255, k * 60, 0, 255)
            b += struct.pack(order + codes, *vals)
        for f, m in faces:
            tc = [c * 0.25 for c in range(2 * len(f))]
            b += struct.pack(order + "B%di" % len(f), len(f), *f)
            b += struct.pack(order + "B%df" % len(tc), len(tc), *tc)
            b += struct.pack(order + "iHd", m, 1, 0.5)
        put("ply_binary", f"attributes_{fmt}.ply", hdr(fmt).encode() + b)
    put("points_ply", "attributes.ply", hdr("ascii").split("element face")[0] + "end_header\n"
        + "".join(" ".join(map(str, p)) + " 0 0 1 1 2 3 4 " + " ".join(map(str, vals)) + "\n"
                  for p in pts))


def stl_attributes():
    b = b"COLOR=\x80\x40\x20\xff MATERIAL=".ljust(80, b" ") + struct.pack("<I", len(TRIS))
    for k, t in enumerate(TRIS):
        b += struct.pack("<3f", 0, 0, 1) + b"".join(struct.pack("<3f", *P[i]) for i in t)
        b += struct.pack("<H", [0x8000 | 0x7c00, 0x001f, 0, 0xffff, 7, 0x8000][k])
    put("stl_binary", "attribute_words.stl", b)


def msh_fields():
    n = len(P)
    nodes22 = "".join(f"{10 + i} {x} {y} {z}\n" for i, (x, y, z) in enumerate(P))
    els = ["1 15 2 5 1 10", "2 2 2 6 2 10 11 12"] + \
        [f"{3 + k} 4 2 {7 + k} {3 + k} " + " ".join(str(10 + i) for i in t)
         for k, t in enumerate(TETS)]
    data1 = "".join(f"{10 + i} {0.1 * i}\n" for i in range(n))
    data3 = "".join(f"{10 + i} {i} 0 -1\n" for i in range(n - 1))
    put("msh22_ascii", "fields.msh",
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n3 7 \"inner\"\n3 8 \"outer\"\n"
        f"$EndPhysicalNames\n$Nodes\n{n}\n" + nodes22 + f"$EndNodes\n$Elements\n{len(els)}\n"
        + "\n".join(els) + "\n$EndElements\n"
        f"$NodeData\n1\n\"size\"\n1\n0.0\n3\n0\n1\n{n}\n" + data1 + "$EndNodeData\n"
        f"$NodeData\n2\n\"velocity\"\n\"extra\"\n2\n1.5\n2\n4\n0\n3\n{n - 1}\n7\n" + data3
        + "$EndNodeData\n$ElementData\n1\n\"e\"\n1\n0\n3\n0\n1\n1\n3 1\n$EndElementData\n")

    def bin_node_data(name, comps, rows, fmt_end=b""):
        b = f"$NodeData\n1\n\"{name}\"\n1\n0.0\n3\n0\n{comps}\n{len(rows)}\n".encode()
        for tag, vals in rows:
            b += struct.pack("<i%dd" % comps, tag, *vals)
        return b + b"\n$EndNodeData\n"
    b = b"$MeshFormat\n2.2 1 8\n" + struct.pack("<i", 1) + b"\n$EndMeshFormat\n$Nodes\n"
    b += f"{n}\n".encode() + b"".join(struct.pack("<i3d", 10 + i, *p) for i, p in enumerate(P))
    b += b"\n$EndNodes\n$Elements\n" + f"{1 + len(TETS)}\n".encode()
    b += struct.pack("<3i", 15, 1, 2) + struct.pack("<4i", 1, 5, 1, 10)
    b += struct.pack("<3i", 4, len(TETS), 2)
    for k, t in enumerate(TETS):
        b += struct.pack("<7i", 2 + k, 7 + k, 9, *(10 + i for i in t))
    b += b"\n$EndElements\n"
    b += bin_node_data("size", 1, [(10 + i, [0.1 * i]) for i in range(n)])
    b += bin_node_data("v", 3, [(12, [1, 2, 3]), (10, [4, 5, 6])])
    put("msh22_binary", "fields.msh", b)

    # 4.1: physical tags live in $Entities; $NodeData as in 2.2.
    text41 = open(ROOT / "msh41_ascii" / "seed_tets.msh").read()
    text41 = text41.replace("1 0 0 0 1 1 1 0 0\n", "1 0 0 0 1 1 1 2 7 8 0\n")
    put("msh41_ascii", "fields.msh", text41 + f"$NodeData\n1\n\"size\"\n1\n0.0\n3\n0\n1\n{n}\n"
        + data1 + "$EndNodeData\n$NodeData\n1\n\"d\"\n0\n3\n0\n3\n2\n10 1 2 3\n14 4 5 6\n"
        "$EndNodeData\n")
    b41 = (ROOT / "msh41_binary" / "seed_tets.msh").read_bytes()
    put("msh41_binary", "fields.msh", b41 + bin_node_data("size", 1, [(10 + i, [0.5 * i])
                                                                      for i in range(n)])
        + bin_node_data("d", 2, [(14, [1, 2])]))


for make in (obj_attributes, ply_attributes, stl_attributes, msh_fields):
    make()
