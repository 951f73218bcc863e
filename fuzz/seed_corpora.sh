#!/usr/bin/env bash
# Fills the working corpora fuzz/corpus/TARGET/ (git-ignored) from the readers' test fixtures and
# the committed seeds of fuzz/corpus-seeds/TARGET/; gzip variants (.nii.gz, meshes) and the Zarr
# target's packed stores (zarr_seeds.py) are made here.
# Existing corpus entries are kept, so a corpus grows across runs.
set -euo pipefail
cd "$(dirname "$0")"
io=../crates/isogrid-io/tests/fixtures
cgc=../crates/isogrid/tests/fixtures
add() { # TARGET FILE...
    local target=$1; shift
    mkdir -p "corpus/$target"
    for f in "$@"; do [ -f "$f" ] && cp "$f" "corpus/$target/"; done
    return 0
}
add nifti "$io"/*.nii
add nifti_gz "$io"/*.nii.gz
for f in "$io"/*.nii; do gzip -9nc "$f" > "corpus/nifti_gz/$(basename "$f").gz"; done
add nrrd "$io"/*.nrrd
add npy "$io"/*.npy
add tiff "$io"/*.tif
add dicom "$io"/dicom_*/*.dcm
add metaimage "$io"/*.mha
add mrc "$io"/*.mrc "$io"/*.map
add mgh "$io"/*.mgh "$io"/*.mgz
for f in "$io"/*.mgz; do gzip -dc "$f" > "corpus/mgh/$(basename "$f" .mgz).mgh"; done
add cgc "$cgc"/*.cgc
add seg_nrrd "$io"/labels/*.seg.nrrd
for target in corpus-seeds/*/; do
    add "$(basename "$target")" "$target"*
done
# The detached NRRD fixture in the target's input format: header naming d.raw, blank line, data.
{ sed 's/^data file: .*/data file: d.raw/' "$io/u8_detached.nhdr"; echo; cat "$io/u8_detached.raw"; } \
    > corpus/nrrd_detached/u8_detached.nhdr
for mesh in ply stl obj; do
    for f in corpus-seeds/$mesh/*; do gzip -9nc "$f" > "corpus/$mesh/$(basename "$f").gz"; done
done
python3 zarr_seeds.py "$io/zarr" corpus/zarr
for d in corpus/*/; do echo "$(basename "$d"): $(ls "$d" | wc -l) files"; done
