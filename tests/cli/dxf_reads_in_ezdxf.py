#!/usr/bin/env python3
"""Reads a DXF export with ezdxf, a DXF library CAD scripting uses, and compares it with its network.

dxf_reads_in_ezdxf.py NETWORK.json EXPORT.dxf

Checks that ezdxf's audit finds no error, that every pipe, elbow and tee of the network (none of
them rejected or deleted) is one 3-D polyline on the layer of its type, and that each polyline's
vertices and extended data (radius, run, bend radius, confidence, status) are the network's.
Exits 1 naming the first difference.
"""
import json
import math
import sys

import ezdxf

TOLERANCE = 1e-6  # m: the export writes coordinates with 9 significant decimals at least


def fail(message):
    print(f"FAIL: {message}", file=sys.stderr)
    sys.exit(1)


def close(a, b):
    return all(math.isclose(x, y, abs_tol=TOLERANCE) for x, y in zip(a, b))


def main(network_path, dxf_path):
    with open(network_path, encoding="utf-8") as stream:
        network = json.load(stream)
    try:
        document = ezdxf.readfile(dxf_path)
    except (IOError, ezdxf.DXFError) as error:
        fail(f"ezdxf cannot read {dxf_path}: {error}")
    auditor = document.audit()
    if auditor.has_errors:
        fail(f"ezdxf's audit of {dxf_path}: {[str(error) for error in auditor.errors]}")
    if document.units != 6:  # ezdxf.units.M
        fail(f"{dxf_path}: drawing units {document.units}, expected 6 (metres)")

    polylines = {}
    for entity in document.modelspace():
        if entity.dxftype() != "POLYLINE" or not entity.is_3d_polyline:
            fail(f"{entity.dxftype()} is no 3-D polyline")
        tags = entity.get_xdata("PIPERUN")
        name = tags[0].value
        polylines[name] = (entity, [tag.value for tag in tags[1:]])

    run_of = {}
    for run in network["runs"]:
        run_of.update({("pipe", pipe): run["id"] for pipe in run["pipes"]})
        run_of.update({("joint", joint): run["id"] for joint in run["joints"]})
    expected = []  # name, layer, element, bend radius, run
    for pipe in network["pipes"]:
        if pipe["status"] != "deleted":
            run = run_of.get(("pipe", pipe["id"]), pipe.get("run") if pipe.get("run") is not None else -1)
            expected.append((f"pipe-{pipe['id']}", "PIPE", pipe, 0.0, run))
    for joint in network["joints"]:
        if joint["status"] != "rejected":
            expected.append((f"{joint['type']}-{joint['id']}", joint["type"].upper(), joint,
                             joint.get("bend_radius", 0.0), run_of.get(("joint", joint["id"]), -1)))
    if len(polylines) != len(expected):
        fail(f"{len(polylines)} polylines for {len(expected)} elements")

    for name, layer, element, bend_radius, expected_run in expected:
        if name not in polylines:
            fail(f"no polyline named {name}")
        entity, (radius, run, bend, confidence, status) = polylines[name]
        if entity.dxf.layer != layer:
            fail(f"{name} is on layer {entity.dxf.layer}, not {layer}")
        vertices = [tuple(vertex.dxf.location) for vertex in entity.vertices]
        axis = element["axis"]
        if len(vertices) != len(axis) or not all(close(v, a) for v, a in zip(vertices, axis)):
            fail(f"{name}'s vertices are not its centre line")
        if not close((radius, bend, confidence), (element["radius"], bend_radius, element["confidence"])):
            fail(f"{name}'s radius, bend radius or confidence differ")
        if run != expected_run:
            fail(f"{name} is in run {run}, not {expected_run}")
        if status != element["status"]:
            fail(f"{name} is {status}, not {element['status']}")
    print(f"ezdxf {ezdxf.__version__}: {len(expected)} polylines read back, audit clean")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        sys.exit(1)
    main(sys.argv[1], sys.argv[2])
