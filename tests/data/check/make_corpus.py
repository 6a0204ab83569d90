#!/usr/bin/env python3
"""Writes the defect corpus of tests/test_check.cpp: small meshes, each with one known
defect, in the four formats `tessref check` reads. The files are committed; this script
documents how they were made and regenerates them (python3, standard library only):

    python3 tests/data/check/make_corpus.py

Closed meshes start from the unit cube [0,1]^3 (8 vertices, 12 triangles, counter-
clockwise seen from outside). Open ones are small terrains seen from +z.
"""
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))

CUBE_V = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
CUBE_F = [(0, 2, 1), (0, 3, 2), (4, 5, 6), (4, 6, 7), (0, 1, 5), (0, 5, 4),
          (1, 2, 6), (1, 6, 5), (2, 3, 7), (2, 7, 6), (3, 0, 4), (3, 4, 7)]
CUBE_QUADS = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]


def fmt(x):
    return repr(float(x)) if not float(x).is_integer() else str(int(x))


def write_off(name, V, F, comment):
    with open(os.path.join(HERE, name), "w") as f:
        # No comment line: OpenMesh's OFF reader does not accept one in the header.
        f.write("OFF\n%d %d 0\n" % (len(V), len(F)))
        for p in V:
            f.write(" ".join(fmt(c) for c in p) + "\n")
        for face in F:
            f.write("%d %s\n" % (len(face), " ".join(str(i) for i in face)))


def write_obj(name, V, F, comment):
    with open(os.path.join(HERE, name), "w") as f:
        f.write("# %s\n" % comment)
        for p in V:
            f.write("v %s\n" % " ".join(fmt(c) for c in p))
        for face in F:
            f.write("f %s\n" % " ".join(str(i + 1) for i in face))


def write_ply(name, V, F, comment, binary=False):
    header = ("ply\nformat %s 1.0\ncomment %s\nelement vertex %d\nproperty float x\n"
              "property float y\nproperty float z\nelement face %d\n"
              "property list uchar int vertex_indices\nend_header\n") % (
        "binary_little_endian" if binary else "ascii", comment, len(V), len(F))
    with open(os.path.join(HERE, name), "wb") as f:
        f.write(header.encode())
        for p in V:
            if binary:
                f.write(struct.pack("<3f", *p))
            else:
                f.write((" ".join(fmt(c) for c in p) + "\n").encode())
        for face in F:
            if binary:
                f.write(struct.pack("<B%di" % len(face), len(face), *face))
            else:
                f.write(("%d %s\n" % (len(face), " ".join(str(i) for i in face))).encode())


def facet_normal(a, b, c):
    u = [b[i] - a[i] for i in range(3)]
    v = [c[i] - a[i] for i in range(3)]
    n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
    length = math.sqrt(sum(x * x for x in n))
    return [x / length for x in n] if length > 0 else [0.0, 0.0, 0.0]


def write_stl(name, V, F, comment, binary=False):
    tris = []
    for face in F:
        for k in range(1, len(face) - 1):
            tris.append((V[face[0]], V[face[k]], V[face[k + 1]]))
    path = os.path.join(HERE, name)
    if binary:
        with open(path, "wb") as f:
            f.write(comment.encode()[:80].ljust(80, b" "))
            f.write(struct.pack("<I", len(tris)))
            for t in tris:
                f.write(struct.pack("<12fH", *facet_normal(*t), *t[0], *t[1], *t[2], 0))
    else:
        with open(path, "w") as f:
            f.write("solid %s\n" % comment)
            for t in tris:
                f.write("  facet normal %s\n    outer loop\n" % " ".join("%.9g" % x for x in facet_normal(*t)))
                for p in t:
                    f.write("      vertex %s\n" % " ".join("%.9g" % c for c in p))
                f.write("    endloop\n  endfacet\n")
            f.write("endsolid %s\n" % comment)


def two_cubes(offset):
    """Two unit cubes, the second moved by `offset`, welded where positions coincide."""
    V, F, index = [], [], {}
    for off in ((0, 0, 0), offset):
        remap = []
        for p in CUBE_V:
            q = tuple(p[i] + off[i] for i in range(3))
            if q not in index:
                index[q] = len(V)
                V.append(q)
            remap.append(index[q])
        F += [tuple(remap[i] for i in f) for f in CUBE_F]
    return V, F


def terrain(n, height, skip=()):
    """An n x n grid of quads over [0,n]^2 split into triangles, z = height(x, y)."""
    V = [(x, y, height(x, y)) for y in range(n + 1) for x in range(n + 1)]
    F = []
    for j in range(n):
        for i in range(n):
            a, b = j * (n + 1) + i, j * (n + 1) + i + 1
            c, d = b + n + 1, a + n + 1
            if (i, j) in skip:
                continue
            F += [(a, b, c), (a, c, d)]
    return V, F


def main():
    V, F = CUBE_V, CUBE_F
    comment = "unit cube, closed, outward"
    write_off("cube.off", V, F, comment)
    write_obj("cube.obj", V, F, comment)
    write_ply("cube.ply", V, F, comment)
    write_ply("cube_binary.ply", V, F, comment, binary=True)
    write_stl("cube.stl", V, F, comment)
    write_stl("cube_binary.stl", V, F, comment, binary=True)
    write_obj("cube_quads.obj", V, CUBE_QUADS, "unit cube as six quads, closed")

    # A hole: the top triangle (4,5,6), face 2, removed.
    F = [f for k, f in enumerate(CUBE_F) if k != 2]
    write_off("hole.off", CUBE_V, F, "cube without face (4,5,6): a hole at the top")
    write_stl("hole.stl", CUBE_V, F, "cube without its top face (4,5,6)")

    # A flipped face: face 0 reversed.
    F = list(CUBE_F)
    F[0] = tuple(reversed(F[0]))
    write_obj("flipped_face.obj", CUBE_V, F, "cube with face 0 reversed")
    write_stl("flipped_face.stl", CUBE_V, F, "cube with facet 0 reversed")

    # Every face reversed: consistent, but inside out.
    F = [tuple(reversed(f)) for f in CUBE_F]
    write_off("inverted.off", CUBE_V, F, "cube with every face reversed: inside out")
    write_stl("inverted.stl", CUBE_V, F, "cube inside out")

    # A duplicate face: face 12 repeats face 3.
    F = CUBE_F + [CUBE_F[3]]
    write_off("duplicate_face.off", CUBE_V, F, "cube plus a copy of face 3 as face 12")
    write_stl("duplicate_face.stl", CUBE_V, F, "cube plus a copy of facet 3")

    # An unwelded vertex: vertex 8 is a copy of vertex 6, used by the two top faces.
    V = CUBE_V + [CUBE_V[6]]
    F = [tuple(8 if (k in (2, 3) and i == 6) else i for i in f) for k, f in enumerate(CUBE_F)]
    write_off("duplicate_vertex.off", V, F, "cube whose top faces use vertex 8, a copy of vertex 6")
    write_ply("duplicate_vertex.ply", V, F, "cube whose top faces use vertex 8, a copy of vertex 6")

    # A nearly coincident vertex: vertex 8 is vertex 6 raised by 1e-7.
    V = CUBE_V + [(1, 1, 1 + 1e-7)]
    write_off("near_vertex.off", V, F, "cube whose top faces use vertex 8, 1e-7 above vertex 6")
    write_stl("near_vertex.stl", V, F, "cube whose top facets use a corner 1e-7 above (1,1,1)")

    # A non-manifold edge: two cubes sharing the edge x = y = 1.
    V, F = two_cubes((1, 1, 0))
    write_off("nonmanifold_edge.off", V, F, "two cubes sharing the edge x = y = 1")
    write_stl("nonmanifold_edge.stl", V, F, "two cubes sharing the edge x = y = 1")

    # A non-manifold vertex (two fans): two cubes sharing the corner (1,1,1).
    V, F = two_cubes((1, 1, 1))
    write_off("nonmanifold_vertex.off", V, F, "two cubes sharing the corner (1,1,1)")
    write_stl("nonmanifold_vertex.stl", V, F, "two cubes sharing the corner (1,1,1)")

    # A T-junction: the bottom triangle (0,2,1) split at m = (0.5,0,0), the midpoint of
    # edge 0-1, whose other face (0,1,5) is not split.
    V = CUBE_V + [(0.5, 0, 0)]
    F = list(CUBE_F)
    F[0] = (0, 2, 8)
    F.append((8, 2, 1))
    write_off("t_junction.off", V, F, "cube with a T-junction: vertex 8 on edge 0-1 of face 4")
    write_stl("t_junction.stl", V, F, "cube with a T-junction at (0.5,0,0)")

    # A sliver: the same T-junction closed by the zero-area face (0,8,1), face 13.
    F = F + [(0, 8, 1)]
    write_off("sliver.off", V, F, "cube whose T-junction is closed by the zero-area face 13")
    write_stl("sliver.stl", V, F, "cube with a zero-area facet (0,0,0) (0.5,0,0) (1,0,0)")

    # A repeated vertex: face 12 is (0,0,1).
    F = CUBE_F + [(0, 0, 1)]
    write_off("repeated_vertex.off", CUBE_V, F, "cube plus face 12 = (0,0,1), a repeated vertex")
    write_obj("repeated_vertex.obj", CUBE_V, F, "cube plus face 13 (1-based) = 1 1 2, a repeated vertex")
    write_stl("repeated_vertex.stl", CUBE_V, F, "cube plus a facet with two equal corners")

    # Terrains, seen from +z.
    def hills(x, y):
        return round(0.3 * math.sin(0.9 * x) + 0.2 * math.cos(0.7 * y), 6)

    V, F = terrain(6, hills)
    write_obj("terrain.obj", V, F, "terrain, 6 x 6 quads over [0,6]^2, open, crack-free")
    write_stl("terrain.stl", V, F, "terrain, 6 x 6 quads, open")
    V, F = terrain(6, hills, skip={(2, 3)})
    write_obj("terrain_hole.obj", V, F, "terrain with the quad [2,3] x [3,4] missing: a hole inside")

    # Two patches with mismatched outer levels on their shared edge x = 1: the left patch
    # [0,1]^2 has 2 segments there (vertices at y = 0, 0.5, 1), the right patch [1,2]x[0,1]
    # has 1. On the curved surface z = 0.2 y^2 the left patch's vertex (1, 0.5, 0.05) lies
    # on the right patch's edge seen from above, 0.05 below it: a crack.
    def z(x, y):
        return 0.2 * y * y

    V, index = [], {}

    def vid(x, y):
        if (x, y) not in index:
            index[(x, y)] = len(V)
            V.append((x, y, z(x, y)))
        return index[(x, y)]

    F = []
    for j in range(2):
        for i in range(2):
            x0, y0, x1, y1 = i * 0.5, j * 0.5, (i + 1) * 0.5, (j + 1) * 0.5
            a, b, c, d = vid(x0, y0), vid(x1, y0), vid(x1, y1), vid(x0, y1)
            F += [(a, b, c), (a, c, d)]
    a, b, c, d = vid(1, 0), vid(2, 0), vid(2, 1), vid(1, 1)
    F += [(a, b, c), (a, c, d)]
    write_obj("patches_mismatched.obj", V, F,
              "two patches, outer levels 2 and 1 on their shared edge x = 1: a T-junction crack at (1, 0.5)")


if __name__ == "__main__":
    main()
