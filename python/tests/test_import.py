"""What `import isogrid` does to the process, and how it fails where it cannot work."""

import glob
import importlib.machinery
import os
import subprocess
import sys

from conftest import REPO

# A headless environment: no display, no Wayland runtime directory, nobody steering Mesa.
HEADLESS = {
    k: v
    for k, v in os.environ.items()
    if k
    not in ("DISPLAY", "WAYLAND_DISPLAY", "XDG_RUNTIME_DIR", "NODEVICE_SELECT", "DRI_PRIME", "MESA_VK_DEVICE_SELECT")
}


def test_import_leaves_the_environment_alone():
    # Every child process inherits os.environ: importing a library must not change it.
    code = "import os, isogrid; print('NODEVICE_SELECT' in os.environ)"
    out = subprocess.run([sys.executable, "-c", code], env=HEADLESS, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False", out.stderr


def test_import_from_the_source_folder_says_the_extension_is_missing():
    # From python/, `isogrid` is the source folder; it has no compiled extension unless built in
    # place, and Python's own message blamed a circular import.
    source = REPO / "python" / "isogrid"
    built_in_place = any(
        glob.glob(str(source / ("_isogrid" + s))) for s in importlib.machinery.EXTENSION_SUFFIXES
    )
    out = subprocess.run(
        [sys.executable, "-c", "import isogrid"], cwd=REPO / "python", capture_output=True, text=True
    )
    if built_in_place:
        assert out.returncode == 0, out.stderr
        return
    assert out.returncode != 0
    last = out.stderr.strip().splitlines()[-1]
    assert "circular import" not in last, out.stderr
    assert "compiled extension (_isogrid) is not in" in last and "Run Python from another folder" in last, out.stderr
