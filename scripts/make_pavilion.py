#!/usr/bin/python3
"""Writes data/models/pavilion.obj: the accuracy study's second model (bench/pavilion_site.yaml),
made of what the sample gate lacks: a roof slab overhanging its columns by 2 m, columns 0.15 m
thin, a fin wall 0.1 m thick and a balcony cantilevered from it. Boxes in metres, z up; each
box's faces wound counter-clockwise seen from outside."""
import os
import sys

BOXES = [
    # columns: 4 × 3, 2.4 m apart, 0.15 m square, 3 m tall
    *[((x - 0.075, y - 0.075, 0.0), (x + 0.075, y + 0.075, 3.0)) for x in (-3.6, -1.2, 1.2, 3.6) for y in (-1.2, 1.2, 3.6)],
    ((-5.0, -3.2, 3.0), (5.0, 4.6, 3.25)),   # the roof slab, 2 m past the southern columns
    ((-6.2, -1.5, 0.0), (-6.1, 3.5, 3.0)),   # a fin wall 0.1 m thick west of the columns
    ((-7.6, -0.5, 1.5), (-6.2, 2.5, 1.62)),  # a balcony slab cantilevered west from the fin
    ((-7.6, -0.5, 1.62), (-7.55, 2.5, 2.6)), # its thin parapet
]
FACES = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "data", "models", "pavilion.obj")
    lines = ["# skylit's accuracy-study pavilion (scripts/make_pavilion.py): overhangs and thin parts, metres, z up"]
    for b, (lo, hi) in enumerate(BOXES):
        for k in range(8):
            lines.append("v %.3f %.3f %.3f" % (hi[0] if k & 1 else lo[0], hi[1] if k & 2 else lo[1], hi[2] if k & 4 else lo[2]))
    for b in range(len(BOXES)):
        for f in FACES:
            lines.append("f " + " ".join(str(8 * b + i + 1) for i in f))
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
