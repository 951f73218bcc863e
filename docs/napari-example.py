"""isogrid in napari: a volume and its Marching Cubes surface, with a live isovalue slider.

    pip install ./python "napari[all]"
    python docs/napari-example.py [volume.nii.gz]

Without an argument it shows a synthetic blob volume. napari lays an array out by its axes, so a
C-ordered array ``a[z, y, x]`` is shown with its first axis as napari's first: the surface is taken
in index space (sample (i, j, k) at (i, j, k), isogrid's (x, y, z) order) and its columns reversed
to (z, y, x), which puts it on the image. Moving the slider re-extracts the surface (Marching
Cubes runs in milliseconds on volumes of this size) and replaces the layer's data.
"""

import sys

import numpy as np

import isogrid


def blob_volume(n=96):
    """(z, y, x) float32: a sum of sinusoids, a few smooth blobs."""
    z, y, x = np.mgrid[:n, :n, :n].astype(np.float32) * (6.0 / n)
    return np.sin(x) * np.cos(y) + np.sin(y) * np.cos(z) + np.sin(z) * np.cos(x)


def surface_data(volume, iso):
    """napari ``Surface`` data for the isosurface of ``volume`` (a C array ``[z, y, x]``) at ``iso``:
    ``(vertices, faces, values)`` with vertices in the array's (z, y, x) index order and the
    volume's value at each vertex (``iso`` up to interpolation) as ``values``."""
    vertices, faces = isogrid.marching_cubes(volume, iso=iso, space="index")
    vertices = np.ascontiguousarray(vertices[:, ::-1])
    return vertices, faces, np.full(len(vertices), iso, np.float32)


def main():
    import napari
    from magicgui import magicgui

    if len(sys.argv) > 1:
        # load_volume's array is C-ordered [z, y, x], napari's order as it is.
        volume = isogrid.load_volume(sys.argv[1]).array
    else:
        volume = blob_volume()
    lo, hi = float(np.nanmin(volume)), float(np.nanmax(volume))
    viewer = napari.Viewer(ndisplay=3)
    viewer.add_image(volume, name="volume", rendering="attenuated_mip", opacity=0.3)
    iso = lo + 0.5 * (hi - lo)
    surface = viewer.add_surface(surface_data(volume, iso), name="isosurface", colormap="viridis")

    @magicgui(auto_call=True, iso={"widget_type": "FloatSlider", "min": lo, "max": hi})
    def isovalue(iso: float = iso):
        surface.data = surface_data(volume, iso)

    viewer.window.add_dock_widget(isovalue, area="right")
    napari.run()


if __name__ == "__main__":
    main()
