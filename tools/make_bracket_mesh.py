#!/usr/bin/env python3
"""Build the bracket tetrahedral mesh, scenes/meshes/bracket.msh.

The part is a bar 1.0 x 0.2 x 0.2 m along x (x in [0, 1], y and z in
[0, 0.2], z up) with four cylindrical holes through it along y. A size field
grades the tets finer near the holes, where a bent or loaded bracket has its
stress concentrations. Gmsh tetrahedralises it into ~100k-150k linear tets,
written as Gmsh ASCII MSH 4.1 (which sim/mesh_io.c reads) with only the
volume's tetrahedra and the nodes they use.

The output file is shipped in the repository: nothing is generated or
downloaded when a scene runs. This script is only needed to rebuild it, and
needs the PyPI `gmsh` package (it bundles the Gmsh library):

    python3 -m venv /tmp/venv-gmsh
    /tmp/venv-gmsh/bin/pip install gmsh
    /tmp/venv-gmsh/bin/python tools/make_bracket_mesh.py [--out PATH]

If `import gmsh` fails on a bare Debian, the wheel wants a few X/GL shared
libraries: apt-get install libglu1-mesa libxcursor1 libxinerama1 libxft2.

The output is deterministic for a given gmsh version (one thread, a fixed
random seed, fixed options); the committed file was made with the version
the script prints.
"""
import argparse
import os
import sys

try:
    import gmsh
except ImportError as e:
    sys.exit(f"make_bracket_mesh.py: {e}: needs the PyPI gmsh package (see the top of this file)")

# Geometry, metres.
LX, LY, LZ = 1.0, 0.2, 0.2
# Holes along y: (centre x, centre z, radius). None reaches x = 0, where the
# scene pins the bar, so the pinned face stays a full rectangle.
HOLES = [(0.20, 0.10, 0.050), (0.42, 0.10, 0.040), (0.62, 0.10, 0.040), (0.82, 0.10, 0.030)]

# Target edge lengths: fine at the hole walls, coarse in the bulk, linear in
# between over GRADE metres. Tuned for ~120k tets.
H_MIN, H_MAX, GRADE = 0.0065, 0.0145, 0.06


def build_geometry():
    bar = gmsh.model.occ.addBox(0, 0, 0, LX, LY, LZ)
    cyls = [gmsh.model.occ.addCylinder(x, 0, z, 0, LY, 0, r) for x, z, r in HOLES]
    out, _ = gmsh.model.occ.cut([(3, bar)], [(3, c) for c in cyls])
    gmsh.model.occ.synchronize()
    assert len(out) == 1 and out[0][0] == 3, out
    return out[0][1]


def size_field(volume):
    # The hole walls are the volume's cylindrical faces; the distance to them
    # drives the size. Sizes from points, curvature and the boundary are off
    # so this field alone decides (otherwise the defaults would refine the
    # hole edges further and the tet count would be hard to aim).
    faces = [t for _, t in gmsh.model.getBoundary([(3, volume)], oriented=False)]
    holes = [t for t in faces if gmsh.model.getType(2, t) == "Cylinder"]
    assert len(holes) == len(HOLES), holes
    dist = gmsh.model.mesh.field.add("Distance")
    gmsh.model.mesh.field.setNumbers(dist, "SurfacesList", holes)
    gmsh.model.mesh.field.setNumber(dist, "Sampling", 200)
    thr = gmsh.model.mesh.field.add("Threshold")
    gmsh.model.mesh.field.setNumber(thr, "InField", dist)
    gmsh.model.mesh.field.setNumber(thr, "SizeMin", H_MIN)
    gmsh.model.mesh.field.setNumber(thr, "SizeMax", H_MAX)
    gmsh.model.mesh.field.setNumber(thr, "DistMin", 0.0)
    gmsh.model.mesh.field.setNumber(thr, "DistMax", GRADE)
    gmsh.model.mesh.field.setAsBackgroundMesh(thr)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)


def stats(path):
    """Counts, quality, orientation and valence of the saved tets."""
    types, tags, nodes = gmsh.model.mesh.getElements(3)
    assert list(types) == [4], types  # linear tets only
    tags, conn = list(tags[0]), list(nodes[0])
    ntet = len(tags)
    # Nodes the tets use (with SaveAll = 0 and a physical volume these are
    # the ones written).
    used = sorted(set(conn))
    coords = {}
    ntags, xyz, _ = gmsh.model.mesh.getNodes()
    for i, t in enumerate(ntags):
        coords[t] = xyz[3 * i:3 * i + 3]

    # ek refuses a tet with det[X1-X0, X2-X0, X3-X0] < 0 unless the scene
    # asks it to fix orientations; Gmsh's convention is the same positive
    # one, checked here so the file never needs the fix.
    neg = 0
    tets_of = {t: 0 for t in used}
    nbrs = {t: set() for t in used}
    for e in range(ntet):
        v = conn[4 * e:4 * e + 4]
        p = [coords[t] for t in v]
        a = [p[1][k] - p[0][k] for k in range(3)]
        b = [p[2][k] - p[0][k] for k in range(3)]
        c = [p[3][k] - p[0][k] for k in range(3)]
        det = (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
               a[2] * (b[0] * c[1] - b[1] * c[0]))
        neg += det <= 0
        for t in v:
            tets_of[t] += 1
            nbrs[t].update(v)
    inc = list(tets_of.values())
    deg = [len(s) - 1 for s in nbrs.values()]

    gamma = gmsh.model.mesh.getElementQualities(tags, "gamma")
    sicn = gmsh.model.mesh.getElementQualities(tags, "minSICN")
    print(f"gmsh {gmsh.__version__}")
    print(f"nodes {len(used)}  tets {ntet}  non-positive orientation {neg}")
    print(f"quality gamma min {min(gamma):.4f} mean {sum(gamma) / ntet:.4f} max {max(gamma):.4f}")
    print(f"quality minSICN min {min(sicn):.4f} mean {sum(sicn) / ntet:.4f} max {max(sicn):.4f}")
    print(f"tets per vertex min {min(inc)} max {max(inc)}; "
          f"edges per vertex min {min(deg)} max {max(deg)}")
    print(f"{path}: {os.path.getsize(path)} bytes")
    return neg


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = os.path.normpath(os.path.join(here, "..", "scenes", "meshes", "bracket.msh"))
    ap.add_argument("--out", default=default)
    args = ap.parse_args()

    gmsh.initialize(["make_bracket_mesh"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 1)
    gmsh.option.setNumber("General.Verbosity", 2)  # warnings and errors only
    # Same file on every run: one thread (parallel meshing orders work by
    # timing) and a fixed seed for the random perturbations of the mesher.
    gmsh.option.setNumber("General.NumThreads", 1)
    gmsh.option.setNumber("Mesh.RandomSeed", 1)
    gmsh.option.setNumber("Mesh.Algorithm", 6)    # Frontal-Delaunay surfaces
    gmsh.option.setNumber("Mesh.Algorithm3D", 1)  # Delaunay volume
    gmsh.option.setNumber("Mesh.ElementOrder", 1)
    gmsh.option.setNumber("Mesh.Optimize", 1)     # removes slivers ek would
    gmsh.option.setNumber("Mesh.OptimizeNetgen", 1)  # pay for in the time step
    gmsh.model.add("bracket")

    volume = build_geometry()
    size_field(volume)
    # Only elements in physical groups are saved (SaveAll = 0): one group on
    # the volume keeps the tets and drops the surface triangles, which ek
    # does not read; the file then holds only the nodes those tets use.
    gmsh.model.addPhysicalGroup(3, [volume], name="bracket")
    gmsh.model.mesh.generate(3)

    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)  # ek reads ASCII only
    gmsh.option.setNumber("Mesh.SaveAll", 0)
    gmsh.option.setNumber("Mesh.SaveParametric", 0)  # ek refuses parametric nodes
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    gmsh.write(args.out)
    neg = stats(args.out)
    gmsh.finalize()
    return 1 if neg else 0


if __name__ == "__main__":
    sys.exit(main())
