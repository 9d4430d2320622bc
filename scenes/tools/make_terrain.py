#!/usr/bin/python3
"""Converts matplotlib's Jacksboro fault DEM into the 16-bit PNG terrain.json uses.

    /usr/bin/python3 scenes/tools/make_terrain.py [DEM.npz] [OUT.png]

Defaults: the file installed by Debian's python-matplotlib-data (a dependency of
python3-matplotlib), and scenes/data/jacksboro_fault_dem.png (git-ignored; written by
scripts/setup.sh). Needs only numpy: run it with Debian's /usr/bin/python3.

The npz holds `elevation` (int16 metres, 344 rows x 403 columns, 3 arc-second
spacing) and its bounding box. The PNG stores the elevation in metres unchanged as
16-bit values (236..1076), row 0 = the array's row 0, so H = metres / 65535 and
terrain.json's scale converts to kilometres. The script checks that the values fit
and prints the ground spacing the scene's plane size is computed from.
"""
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from png16 import write_png16  # noqa: E402

DEFAULT_DEM = "/usr/share/matplotlib/mpl-data/sample_data/jacksboro_fault_dem.npz"
HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_OUT = os.path.normpath(os.path.join(HERE, "..", "data", "jacksboro_fault_dem.png"))


def main():
    src = sys.argv[1] if len(sys.argv) > 1 else DEFAULT_DEM
    out = sys.argv[2] if len(sys.argv) > 2 else DEFAULT_OUT
    if not os.path.isfile(src):
        sys.exit(f"make_terrain.py: {src}: not found (install python-matplotlib-data)")
    with np.load(src) as d:
        elev = np.asarray(d["elevation"])
        dx, dy = float(d["dx"]), float(d["dy"])
        lat = 0.5 * (float(d["ymin"]) + float(d["ymax"]))
    if elev.ndim != 2 or elev.min() < 0 or elev.max() > 65535:
        sys.exit(f"make_terrain.py: {src}: unexpected elevation array {elev.shape} {elev.min()}..{elev.max()}")
    os.makedirs(os.path.dirname(out), exist_ok=True)
    tmp = out + ".tmp"
    write_png16(tmp, elev.astype(np.uint16))
    os.replace(tmp, out)  # atomic: a concurrent reader never sees half a file
    h, w = elev.shape
    # Ground spacing (spherical Earth, R = 6371 km): metres per degree.
    m_per_deg = math.pi / 180 * 6371000.0
    sx, sy = dx * m_per_deg * math.cos(math.radians(lat)), dy * m_per_deg
    print(f"{out}: {w}x{h}, elevation {elev.min()}..{elev.max()} m, spacing {sx:.1f} m (east) x {sy:.1f} m "
          f"(north) at latitude {lat:.3f}; texel-centre extent {(w - 1) * sx / 1000:.3f} x {(h - 1) * sy / 1000:.3f} km")


if __name__ == "__main__":
    main()
