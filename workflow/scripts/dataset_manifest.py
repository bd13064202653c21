"""Data rule entry point: the dataset manifest (data/manifest.json)."""

from scintrack import jobcode
from scintrack.data.manifest import build_manifest
from scintrack.io import pretty_json, write_text

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "dataset_manifest")
manifest = build_manifest(sm.input)
write_text(pretty_json(manifest), sm.output[0])
log.info("%d datasets listed", len(manifest["datasets"]))
