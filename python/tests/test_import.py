"""What `import isogrid` does to the process, and how it fails where it cannot work."""

import os
import subprocess
import sys

# A headless environment: no display, no Wayland runtime directory, nobody steering Mesa.
HEADLESS = {
    k: v
    for k, v in os.environ.items()
    if k not in ("DISPLAY", "WAYLAND_DISPLAY", "XDG_RUNTIME_DIR", "NODEVICE_SELECT", "DRI_PRIME", "MESA_VK_DEVICE_SELECT")
}


def test_import_leaves_the_environment_alone():
    # Every child process inherits os.environ: importing a library must not change it.
    code = "import os, isogrid; print('NODEVICE_SELECT' in os.environ)"
    out = subprocess.run([sys.executable, "-c", code], env=HEADLESS, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False", out.stderr
