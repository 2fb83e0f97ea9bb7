"""Run by tests/apps/test_interop.cpp with Debian's python3-vtk9 (/usr/bin/python3):

    python3 check_vtk.py RUN_DIR

Reads RUN_DIR/vtk/frames.pvd and every .vtu it lists with VTK's own XML reader and compares,
field by field, with what is known independently: positions and object ids with the OBJ frames
(frames/frame_N.obj, `o` blocks in order), the PVD time steps with frame / fps of run.json, and
the per-vertex diagnostics with stats.csv (a frame with halted vertices has halted flags, and no
more flagged vertices than halting events). Prints one line `RESULT {json}`.
"""
import csv
import json
import math
import os
import sys
import xml.etree.ElementTree as ET

import vtk
from vtk.util.numpy_support import vtk_to_numpy

run = sys.argv[1]
fps = json.load(open(os.path.join(run, "run.json")))["fps"]
stats = {int(r["frame"]): r for r in csv.DictReader(open(os.path.join(run, "stats.csv")))}


def read_obj(path):
    v, obj_of = [], []
    k = -1
    for line in open(path):
        if line.startswith("o "):
            k += 1
        elif line.startswith("v "):
            v.append([float(c) for c in line.split()[1:4]])
            obj_of.append(k)
    return v, obj_of


out = {"frames": []}
for ds in ET.parse(os.path.join(run, "vtk", "frames.pvd")).getroot().iter("DataSet"):
    name = ds.get("file")
    frame = int(name[6:11])
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(os.path.join(run, "vtk", name))
    reader.Update()
    grid = reader.GetOutput()
    pts = vtk_to_numpy(grid.GetPoints().GetData())
    ref, obj_of = read_obj(os.path.join(run, "frames", "frame_%05d.obj" % frame))
    pd = grid.GetPointData()
    fields = {pd.GetArrayName(i): vtk_to_numpy(pd.GetArray(i)) for i in range(pd.GetNumberOfArrays())}
    row = {"frame": frame, "points": int(grid.GetNumberOfPoints()), "cells": int(grid.GetNumberOfCells()),
           "obj_vertices": len(ref), "fields": sorted(fields)}
    row["time_error"] = abs(float(ds.get("timestep")) - frame / fps)
    row["max_position_error"] = max(
        (abs(float(pts[i][k]) - ref[i][k]) for i in range(min(len(ref), len(pts))) for k in range(3)), default=0.0)
    row["object_id_mismatches"] = int(sum(int(fields["object_id"][i]) != obj_of[i] for i in range(len(ref))))
    if "velocity" in fields:
        vel = fields["velocity"]
        row["velocity_components"] = int(vel.shape[1])
        row["max_speed"] = float(max(math.sqrt(sum(float(c) ** 2 for c in v)) for v in vel))
        row["velocity_y_mean"] = float(sum(float(v[1]) for v in vel) / len(vel))
        # Per object: smallest and largest y velocity, largest |x| or |z| velocity.
        by = {}
        for i, v in enumerate(vel):
            o = by.setdefault(str(obj_of[i]), [math.inf, -math.inf, 0.0])
            o[0], o[1] = min(o[0], float(v[1])), max(o[1], float(v[1]))
            o[2] = max(o[2], abs(float(v[0])), abs(float(v[2])))
        row["velocity_by_object"] = by
    if "halted" in fields:
        flagged = int(sum(int(h) != 0 for h in fields["halted"]))
        row["halted_flagged"] = flagged
        row["halted_events"] = int(stats[frame]["halted_vertices"]) if frame in stats else 0
    if "half_spaces" in fields:
        row["max_half_spaces"] = int(max(fields["half_spaces"]))
        row["vertices_with_half_spaces"] = int(sum(int(h) > 0 for h in fields["half_spaces"]))
        row["max_constraints"] = int(stats[frame]["constraints"]) if frame in stats else 0
    if "distance" in fields:
        d = [float(x) for x in fields["distance"] if not math.isnan(float(x))]
        row["finite_distances"] = len(d)
        row["min_distance"] = min(d) if d else None
        row["stats_min_distance"] = float(stats[frame]["min_distance"]) if frame in stats and stats[frame][
            "min_distance"] else None
    out["frames"].append(row)
print("RESULT " + json.dumps(out))
