"""Reads a hex mesh written by polyhex with meshio (and, for what meshio 7.0 leaves out, the libraries it
reads with) and prints what a solver would get, as JSON, for tests/nodes/io/test_hex_clients.cpp:

  hexes           hexahedra meshio reads
  min_jacobian    the smallest corner Jacobian determinant over all hexes, in meshio's vertex order
  groups          {name: number of boundary faces} as the format carries them (see below)
  node_sets       {name: number of nodes} (Exodus node sets, Abaqus *NSET, vertices of the Gmsh quads)
  cell_sets       {name: number of cells} as meshio reports cell_sets
  not_boundary    group faces that are not a face of exactly one hex
  inward          group faces whose vertex order turns inward (formats that orient faces)
  outside_nodes   group faces with a node outside the node set of the same name (Exodus, Abaqus)
  thickness       {name: the smallest extent of the group's vertices along x, y or z} (0 for a planar,
                  axis-aligned group such as a side of a box)

Where the groups are, per format (meshio 7.0):
  .e    meshio: point_sets (node sets); side sets (not read by meshio) from the file's netCDF variables
        ss_names, elem_ss<i>, side_ss<i>, through netCDF4 as meshio itself reads Exodus
  .inp  meshio: point_sets (*NSET), cell_sets (*ELSET); *SURFACE lines (skipped by meshio) parsed here
  .msh  meshio: cell_sets, one per physical name (field_data), over the quad blocks
  .vtk  meshio: cell_data, one int array per group family on the quad cells; group = family_<id>
        (`boundary` for the family "boundary")
  .mesh meshio: cell_data medit:ref on the quads = the chart id; group = chart_<ref>
Usage: read_back.py FILE
"""
import json
import sys
from collections import Counter

import meshio
import numpy as np

# VTK_HEXAHEDRON (meshio's hexahedron order): each corner with its three edge neighbours, positively turning.
CORNERS = [(0, 1, 3, 4), (1, 2, 0, 5), (2, 3, 1, 6), (3, 0, 2, 7), (4, 7, 5, 0), (5, 4, 6, 1), (6, 5, 7, 2), (7, 6, 4, 3)]
HEX_FACES = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
# Side numbering from the manuals, 1-based nodes: Exodus II HEX (outward) and Abaqus C3D8.
EXODUS_SIDES = {1: (1, 2, 6, 5), 2: (2, 3, 7, 6), 3: (3, 4, 8, 7), 4: (1, 5, 8, 4), 5: (1, 4, 3, 2), 6: (5, 6, 7, 8)}
ABAQUS_FACES = {1: (1, 2, 3, 4), 2: (5, 8, 7, 6), 3: (1, 5, 6, 2), 4: (2, 6, 7, 3), 5: (3, 7, 8, 4), 6: (4, 8, 5, 1)}


def main(path):
    mesh = meshio.read(path)
    hexes = np.concatenate([c.data for c in mesh.cells if c.type == "hexahedron"])
    P = mesh.points
    jac = min(
        np.linalg.det(np.stack([P[hexes[:, b]] - P[hexes[:, o]], P[hexes[:, c]] - P[hexes[:, o]],
                                P[hexes[:, d]] - P[hexes[:, o]]], axis=1)).min()
        for o, b, c, d in CORNERS)
    face_count = Counter(tuple(sorted(h[list(f)])) for h in hexes for f in HEX_FACES)
    hex_of_face = {tuple(sorted(h[list(f)])): i for i, h in enumerate(hexes) for f in HEX_FACES}
    out = {"hexes": int(len(hexes)), "min_jacobian": float(jac), "groups": {}, "node_sets": {}, "cell_sets": {},
           "not_boundary": 0, "inward": 0, "outside_nodes": 0, "thickness": {}}
    faces = {}  # group name -> list of faces as node tuples (oriented where the format orients them)
    oriented = True
    ext = path.rsplit(".", 1)[-1]
    if ext == "e":
        import netCDF4
        with netCDF4.Dataset(path) as nc:
            names = [b"".join(c).decode() for c in nc.variables["ss_names"][:].data] if "ss_names" in nc.variables else []
            for i, name in enumerate(names, start=1):
                elems = nc.variables[f"elem_ss{i}"][:].data - 1
                sides = nc.variables[f"side_ss{i}"][:].data
                faces[name] = [tuple(hexes[e][k - 1] for k in EXODUS_SIDES[int(s)]) for e, s in zip(elems, sides)]
    elif ext == "inp":
        oriented = False
        name = None
        with open(path) as f:
            for line in f:
                if line.startswith("*"):
                    head = [w.strip() for w in line[1:].split(",")]
                    name = None
                    if head[0].upper() == "SURFACE":
                        name = [w.split("=", 1)[1] for w in head[1:] if w.upper().startswith("NAME=")][0]
                        faces[name] = []
                elif name is not None and line.strip():
                    e, s = [w.strip() for w in line.split(",")]
                    faces[name].append(tuple(hexes[int(e) - 1][k - 1] for k in ABAQUS_FACES[int(s[1:])]))
    elif ext == "msh":
        for name, blocks in mesh.cell_sets.items():
            if name not in mesh.field_data or mesh.field_data[name][1] != 2:
                continue
            faces[name] = [tuple(mesh.cells[b].data[i]) for b, idx in enumerate(blocks) if idx is not None
                           for i in idx]
    elif ext == "vtk":
        for family, arrays in mesh.cell_data.items():
            for block, values in zip(mesh.cells, arrays):
                if block.type != "quad":
                    continue
                for quad, v in zip(block.data, values):
                    if v >= 0:
                        faces.setdefault(family if family == "boundary" else f"{family}_{int(v)}", []).append(tuple(quad))
    elif ext == "mesh":
        for block, refs in zip(mesh.cells, mesh.cell_data["medit:ref"]):
            if block.type == "quad":
                for quad, r in zip(block.data, refs):
                    faces.setdefault(f"chart_{int(r)}", []).append(tuple(quad))
    for name, s in mesh.point_sets.items():
        out["node_sets"][name] = int(len(s))
    for name, blocks in mesh.cell_sets.items():
        out["cell_sets"][name] = int(sum(len(b) for b in blocks if b is not None))
    for name, fs in faces.items():
        out["groups"][name] = len(fs)
        xyz = P[sorted({v for f in fs for v in f})]
        out["thickness"][name] = float((xyz.max(axis=0) - xyz.min(axis=0)).min())
        if ext == "msh":
            out["node_sets"][name] = len({v for f in fs for v in f})
        node_set = set(mesh.point_sets[name].tolist()) if name in mesh.point_sets else None
        for f in fs:
            key = tuple(sorted(f))
            if face_count.get(key, 0) != 1:
                out["not_boundary"] += 1
                continue
            if node_set is not None and not set(f) <= node_set:
                out["outside_nodes"] += 1
            if oriented:
                p = P[list(f)]
                n = np.cross(p[2] - p[0], p[3] - p[1])
                if n.dot(p.mean(axis=0) - P[hexes[hex_of_face[key]]].mean(axis=0)) <= 0:
                    out["inward"] += 1
    print(json.dumps(out))


if __name__ == "__main__":
    main(sys.argv[1])
