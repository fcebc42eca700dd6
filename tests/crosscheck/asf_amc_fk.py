#!/usr/bin/env python3
"""World joint positions of an Acclaim ASF/AMC take, from the format's own definition.

Independent of the C++ reader (common/src/io/asf_amc.cpp): it follows the Acclaim
spec literally, with row vectors and 4x4 matrices, v' = v L. For a bone b:

    L_b = C_b^-1 M_b C_b B_b        world frame F_b = L_b F_parent

where C_b is the bone's `axis` rotation and M_b its frame's dof rotation, both
composed in the axis order (row vectors: "XYZ" is Rx Ry Rz, X applied first),
and B_b the translation by the parent bone's direction * length (0 for the
root's children). The root: L_root = C_r^-1 M_r C_r T(position + (TX, TY, TZ)).
A bone starts at (0,0,0,1) F_b and ends at (direction * length, 1) F_b.
Lengths are converted to metres by 0.0254 / `:units length`.

Usage: asf_amc_fk.py ASF AMC FRAME [FRAME...]  (1-based frame numbers)
Prints a JSON list of {"asf", "amc", "frame", "positions_m": {name: [x, y, z]}}
where names are "root", each bone (its start) and "NAME/end" for leaf bones.
Plain Python (no numpy needed).
"""
import json
import math
import sys


def mat_mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def identity():
    return [[1.0 if i == j else 0.0 for j in range(4)] for i in range(4)]


def rot_row(axis, deg):
    """Row-vector rotation (v' = v R) by `deg` about axis 0/1/2 (right-handed)."""
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    m = identity()
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    # Column form R has R[i][i]=c, R[i][j]=-s, R[j][i]=s, R[j][j]=c; row form is its transpose.
    m[i][i], m[i][j], m[j][i], m[j][j] = c, s, -s, c
    return m


def ordered(order, angles):
    """Row-vector rotation of angles about X, Y, Z applied in `order` (first axis first)."""
    m = identity()
    for a in order:
        m = mat_mul(m, rot_row(a, angles[a]))
    return m


def transpose(m):
    return [[m[j][i] for j in range(4)] for i in range(4)]


def translation(v):
    m = identity()
    m[3][0], m[3][1], m[3][2] = v
    return m


def apply(v, m):
    p = [v[0], v[1], v[2], 1.0]
    return [sum(p[k] * m[k][j] for k in range(4)) for j in range(3)]


def axis_order(token):
    return ["XYZ".index(c) for c in token.upper()]


def read_asf(path):
    lines = [l.split() for l in open(path) if l.split() and not l.lstrip().startswith("#")]
    asf = {"length": 1.0, "deg": True, "bones": {}, "children": {}, "root_order": [],
           "root_axis": [0, 1, 2], "position": [0.0] * 3, "orientation": [0.0] * 3}
    section, bone = None, None
    for t in lines:
        if t[0].startswith(":"):
            section = t[0]
            continue
        if section == ":units":
            if t[0] == "length":
                asf["length"] = float(t[1])
            elif t[0] == "angle":
                asf["deg"] = t[1].lower() == "deg"
        elif section == ":root":
            if t[0] == "order":
                asf["root_order"] = [x.lower() for x in t[1:]]
            elif t[0] == "axis":
                asf["root_axis"] = axis_order(t[1])
            elif t[0] == "position":
                asf["position"] = [float(x) for x in t[1:4]]
            elif t[0] == "orientation":
                asf["orientation"] = [float(x) for x in t[1:4]]
        elif section == ":bonedata":
            if t[0] == "begin":
                bone = {"dof": []}
            elif t[0] == "end":
                n = math.sqrt(sum(x * x for x in bone["direction"]))
                bone["direction"] = [x / n for x in bone["direction"]] if n > 0 else [0.0] * 3
                asf["bones"][bone["name"]] = bone
            elif t[0] == "name":
                bone["name"] = t[1]
            elif t[0] == "direction":
                bone["direction"] = [float(x) for x in t[1:4]]
            elif t[0] == "length":
                bone["length"] = float(t[1])
            elif t[0] == "axis":
                bone["axis"] = [float(x) for x in t[1:4]]
                bone["order"] = axis_order(t[4])
            elif t[0] == "dof":
                bone["dof"] = [x.lower() for x in t[1:]]
        elif section == ":hierarchy" and t[0] not in ("begin", "end"):
            asf["children"].setdefault(t[0], []).extend(t[1:])
    if not asf["deg"]:
        for b in asf["bones"].values():
            b["axis"] = [math.degrees(x) for x in b["axis"]]
        asf["orientation"] = [math.degrees(x) for x in asf["orientation"]]
    return asf


def read_amc(path, wanted):
    frames, current, deg = {}, None, True
    for line in open(path):
        t = line.split()
        if not t or t[0].startswith("#"):
            continue
        if t[0].startswith(":"):
            deg = deg if t[0].upper() != ":RADIANS" else False
            continue
        if len(t) == 1 and t[0].isdigit():
            current = int(t[0])
            if current in wanted:
                frames[current] = {}
            continue
        if current in frames:
            frames[current][t[0]] = [float(x) for x in t[1:]]
    return frames, deg


def pose(asf, values, deg):
    unit = 0.0254 / asf["length"]
    out = {}
    conv = (lambda x: x) if deg else math.degrees
    t, r = list(asf["position"]), [0.0, 0.0, 0.0]
    for name, v in zip(asf["root_order"], values.get("root", [0.0] * 6)):
        if name[0] == "t":
            t["xyz".index(name[1])] += v
        else:
            r["xyz".index(name[1])] += conv(v)
    c = ordered(asf["root_axis"], asf["orientation"])
    root = mat_mul(mat_mul(mat_mul(transpose(c), ordered(asf["root_axis"], r)), c), translation(t))
    out["root"] = [x * unit for x in apply([0, 0, 0], root)]

    def visit(name, parent_frame, offset):
        b = asf["bones"][name]
        m_angles = [0.0, 0.0, 0.0]
        for d, v in zip(b["dof"], values.get(name, [])):
            m_angles["xyz".index(d[1])] = conv(v)
        c = ordered(b["order"], b["axis"])
        local = mat_mul(mat_mul(mat_mul(transpose(c), ordered(b["order"], m_angles)), c),
                        translation(offset))
        frame = mat_mul(local, parent_frame)
        out[name] = [x * unit for x in apply([0, 0, 0], frame)]
        end = [x * b["length"] for x in b["direction"]]
        kids = asf["children"].get(name, [])
        if not kids:
            out[name + "/end"] = [x * unit for x in apply(end, frame)]
        for k in kids:
            visit(k, frame, end)

    for k in asf["children"].get("root", []):
        visit(k, root, [0.0, 0.0, 0.0])
    return out


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    asf_path, amc_path = sys.argv[1], sys.argv[2]
    wanted = [int(x) for x in sys.argv[3:]]
    asf = read_asf(asf_path)
    frames, deg = read_amc(amc_path, set(wanted))
    cases = []
    for f in wanted:
        if f not in frames:
            sys.exit(f"frame {f} not in {amc_path}")
        cases.append({"asf": asf_path, "amc": amc_path, "frame": f,
                      "positions_m": pose(asf, frames[f], deg)})
    json.dump(cases, sys.stdout)


if __name__ == "__main__":
    main()
