"""isogrid from Python: the MNI152 head template as clustered grid cells.

    bash scripts/fetch_data.sh           # data/mni152_t1.nii.gz
    pip install ./python nibabel matplotlib
    python docs/python-example.py [out.png]

Loads the template with nibabel, extracts the isosurface at the paper's normalised isovalue 0.5,
prints the grid's statistics and plots a slice of the volume with the active cells that cross it,
plus all cells as a point cloud. (Rendering the grid itself comes with the renderers.)
"""

import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # write a file; no display needed
import matplotlib.pyplot as plt
import nibabel as nib
import numpy as np

import isogrid

path = Path(__file__).resolve().parents[1] / "data" / "mni152_t1.nii.gz"
out = sys.argv[1] if len(sys.argv) > 1 else "python-example.png"

# nibabel gives a Fortran-ordered array indexed [x, y, z] and the voxel size (sx, sy, sz): exactly
# isogrid's convention (the fastest axis in memory is x), so it is used without a copy.
image = nib.load(path)
volume = np.asanyarray(image.dataobj)
spacing = tuple(float(s) for s in image.header.get_zooms()[:3])
print(f"{path.name}: {volume.shape} {volume.dtype}, spacing {spacing}")

grid = isogrid.extract(volume, iso_normalized=0.5, spacing=spacing)
print(json.dumps(grid.stats, indent=1))
# The same grid through isogrid's own reader (C array [z, y, x]):
assert grid.stats == isogrid.extract(isogrid.load_volume(path), iso_normalized=0.5).stats

cells = grid.cell_positions()  # (N, 3) uint32, (x, y, z) of each active cell's lowest corner
z = volume.shape[2] // 2
crossing = cells[cells[:, 2] == z]

fig, (left, right) = plt.subplots(1, 2, figsize=(11, 5.5))
left.imshow(volume[:, :, z].T, cmap="gray", origin="lower")
left.scatter(crossing[:, 0] + 0.5, crossing[:, 1] + 0.5, s=1, c="tab:orange")
left.set_title(f"slice z = {z}: {len(crossing):,} active cells (iso {grid.info['iso']:.1f})")
every = cells[:: max(1, len(cells) // 60000)]
right.scatter(every[:, 0], every[:, 2], s=0.2, c=every[:, 1], cmap="viridis")
right.set_aspect("equal")
right.set_title(f"{grid.active_cells:,} active cells, side view (x, z), colour = y")
fig.tight_layout()
fig.savefig(out, dpi=110)
print(f"wrote {out}")
