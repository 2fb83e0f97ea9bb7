#!/usr/bin/env python3
"""Writes configs/meshes/body/body_NNN.obj: a closed, breathing and swaying body (an ellipsoid
whose radii pulse and whose centre rises and sways), one OBJ per key, same vertices and faces in
every file. configs/animated_body.yaml drops a cloth on it (`animation` of an obstacle).

    scripts/gen-body-sequence.py [--keys 13] [--out configs/meshes/body]
"""
import argparse
import math
import os

parser = argparse.ArgumentParser()
parser.add_argument("--keys", type=int, default=13)
parser.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "..", "configs", "meshes", "body"))
args = parser.parse_args()
os.makedirs(args.out, exist_ok=True)

rings, segments = 12, 24
faces = []
# Vertex 0: south pole, then rings of `segments`, then the north pole.
north = 1 + (rings - 1) * segments
for s in range(segments):
    faces.append((0, 1 + (s + 1) % segments, 1 + s))
for r in range(rings - 2):
    for s in range(segments):
        a, b = 1 + r * segments + s, 1 + r * segments + (s + 1) % segments
        c, d = a + segments, b + segments
        faces += [(a, b, d), (a, d, c)]
last = 1 + (rings - 2) * segments
for s in range(segments):
    faces.append((north, last + s, last + (s + 1) % segments))

for k in range(args.keys):
    phase = 2 * math.pi * k / (args.keys - 1)
    rx, ry, rz = 0.30 * (1 + 0.08 * math.sin(phase)), 0.22 * (1 - 0.08 * math.sin(phase)), 0.30
    cx, cy = 0.05 * math.sin(phase), 0.10 * k / (args.keys - 1)
    verts = [(cx, cy - ry, 0.0)]
    for r in range(1, rings):
        theta = math.pi * r / rings - math.pi / 2
        for s in range(segments):
            phi = 2 * math.pi * s / segments
            verts.append((cx + rx * math.cos(theta) * math.cos(phi), cy + ry * math.sin(theta),
                          rz * math.cos(theta) * math.sin(phi)))
    verts.append((cx, cy + ry, 0.0))
    with open(os.path.join(args.out, "body_%03d.obj" % k), "w") as f:
        f.write("# ccfr animated body, key %d of %d (scripts/gen-body-sequence.py)\no body\n" % (k, args.keys))
        for v in verts:
            f.write("v %.9f %.9f %.9f\n" % v)
        for t in faces:
            f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))
